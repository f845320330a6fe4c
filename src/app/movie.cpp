// The preview movie of a render's frames (movie.hpp).

#include "app/movie.hpp"

#include "app/resume.hpp"
#include "base/errors.hpp"
#include "base/progress.hpp"
#include "io/atomic_file.hpp"

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

namespace dgv::app {
namespace fs = std::filesystem;

std::string writePreviewMovie(const SceneDesc& scene, int first, int last) {
    // ffmpeg writes a temporary in the output folder, renamed when it succeeds.
    const fs::path moviePath = fs::path(scene.output.dir) / (scene.name + ".mp4");
    const fs::path tmp = fs::path(scene.output.dir) / ("." + scene.name + ".mp4.tmp-" + temporaryTag() + ".mp4");
    const std::string cmd = "ffmpeg -loglevel error -y -framerate " + std::to_string(scene.fps) + " -start_number " +
                            std::to_string(first) + " -i " +
                            shellQuote((fs::path(scene.output.dir) / (scene.name + ".%04d.png")).string()) +
                            " -frames:v " + std::to_string(last - first + 1) +
                            " -c:v libx264 -pix_fmt yuv420p -crf 18 -vf 'pad=ceil(iw/2)*2:ceil(ih/2)*2' " +
                            shellQuote(tmp.string());
    // ffmpeg's exit status is not trusted alone: on a full disk it reports "Error writing
    // trailer ... No space left on device" and exits 0 with a broken file. Anything it says
    // at -loglevel error, an empty file, or (with ffprobe on PATH) a movie that does not
    // decode to every frame fails the step, and the temporary goes.
    const fs::path log = fs::path(scene.output.dir) / ("." + scene.name + ".mp4.log-" + std::to_string(getpid()));
    const int rc = std::system((cmd + " 2> " + shellQuote(log.string())).c_str());
    std::error_code ec;
    std::string said;
    {
        std::ifstream in(log);
        std::getline(in, said);
    }
    fs::remove(log, ec);
    // SIGINT/SIGTERM while ffmpeg ran (system() waits through it): no movie is kept, and the
    // run ends as interrupted (main's handler: exit 130), not with "wrote the preview movie".
    if (cancelRequested()) {
        fs::remove(tmp, ec);
        throw RuntimeError("interrupted while ffmpeg made " + moviePath.string());
    }
    std::string problem;
    if (rc != 0)
        problem = "exit status " + std::to_string(rc);
    else if (!said.empty())
        problem = "it said: " + said;
    else if (!(fs::file_size(tmp, ec) > 0) || ec)
        problem = "it wrote no movie";
    if (problem.empty() && onPath("ffprobe")) {
        const std::string probe =
            "ffprobe -v error -count_frames -select_streams v:0 -show_entries "
            "stream=nb_read_frames -of csv=p=0 " +
            shellQuote(tmp.string()) + " 2>/dev/null";
        std::string counted;
        if (FILE* f = popen(probe.c_str(), "r")) {
            char buf[64];
            while (std::fgets(buf, sizeof buf, f)) counted += buf;
            pclose(f);
        }
        while (!counted.empty() && (counted.back() == '\n' || counted.back() == '\r')) counted.pop_back();
        if (counted != std::to_string(last - first + 1))
            problem = "the movie decodes to " + (counted.empty() ? std::string("no") : counted) + " frames of " +
                      std::to_string(last - first + 1) + " (ffprobe)";
    }
    if (!problem.empty()) {
        fs::remove(tmp, ec);
        throw RuntimeError("ffmpeg failed making " + moviePath.string() + " (" + problem +
                           "); the frames are complete");
    }
    fs::rename(tmp, moviePath, ec);
    if (ec) throw RuntimeError(moviePath.string() + ": " + ec.message());
    return moviePath.string();
}

}  // namespace dgv::app
