// The preview movie of a render's frames (movie.hpp).

#include "app/movie.hpp"

#include "app/resume.hpp"
#include "base/errors.hpp"
#include "base/progress.hpp"
#include "io/atomic_file.hpp"

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <string>

namespace dgv::app {
namespace fs = std::filesystem;

namespace {

/// A shell command's exit status and everything it printed (stdout and stderr, through a pipe:
/// nothing is written beside the movie, whose folder may be full).
struct Captured {
    int status = -1;
    std::string output;
};

Captured runCaptured(const std::string& cmd) {
    Captured c;
    if (FILE* f = popen((cmd + " 2>&1").c_str(), "r")) {
        char buf[4096];
        std::size_t n;
        while ((n = std::fread(buf, 1, sizeof buf, f)) > 0)
            if (c.output.size() < (std::size_t(1) << 20)) c.output.append(buf, n);
        c.status = pclose(f);
    }
    return c;
}

/// ffmpeg's messages as the cause a user can act on: a full disk or a missing encoder named as
/// such, anything else as ffmpeg's first line.
std::string causeOf(const std::string& said) {
    auto has = [&](const char* s) { return said.find(s) != std::string::npos; };
    if (has("No space left on device")) return "the disk is full: No space left on device";
    if (has("Disk quota exceeded")) return "the disk quota is exceeded";
    if (has("Unknown encoder") || has("Encoder not found") || has("Encoder (codec"))
        return "this ffmpeg has no H.264 encoder (libx264): " + libraryMessage(said);
    return "it said: " + libraryMessage(said);
}

/// How many video frames the movie at `path` decodes to, and what the decoder said when it
/// failed: ffprobe when it is on PATH, else ffmpeg itself decoding to per-frame checksums.
struct Decoded {
    long frames = 0;
    std::string said;
};

Decoded decodeMovie(const fs::path& path) {
    Decoded d;
    if (onPath("ffprobe")) {
        const Captured c = runCaptured("ffprobe -v error -count_frames -select_streams v:0 -show_entries "
                                       "stream=nb_read_frames -of csv=p=0 " +
                                       shellQuote(path.string()));
        const std::string line = libraryMessage(c.output);
        char* end = nullptr;
        const long n = std::strtol(line.c_str(), &end, 10);
        if (c.status == 0 && !line.empty() && end && *end == '\0')
            d.frames = n;
        else
            d.said = c.output;
        return d;
    }
    // One line per decoded frame ("0, dts, pts, duration, size, 0xcrc"), '#' comments, and any
    // error on stderr into the same pipe.
    const Captured c = runCaptured("ffmpeg -nostdin -v error -i " + shellQuote(path.string()) +
                                   " -map 0:v:0 -f framecrc -");
    std::istringstream in(c.output);
    std::string other;
    for (std::string line; std::getline(in, line);) {
        if (line.rfind("0,", 0) == 0)
            ++d.frames;
        else if (!line.empty() && line[0] != '#' && other.empty())
            other = line;
    }
    if (c.status != 0 || !other.empty()) d.said = other.empty() ? "exit status " + std::to_string(c.status) : other;
    return d;
}

}  // namespace

std::string writePreviewMovie(const SceneDesc& scene, int first, int last) {
    // ffmpeg writes a temporary in the output folder, renamed when it succeeds.
    const fs::path moviePath = fs::path(scene.output.dir) / (scene.name + ".mp4");
    const fs::path tmp = fs::path(scene.output.dir) / ("." + scene.name + ".mp4.tmp-" + temporaryTag() + ".mp4");
    const std::string cmd = "ffmpeg -nostdin -loglevel error -y -framerate " + std::to_string(scene.fps) +
                            " -start_number " + std::to_string(first) + " -i " +
                            shellQuote((fs::path(scene.output.dir) / (scene.name + ".%04d.png")).string()) +
                            " -frames:v " + std::to_string(last - first + 1) +
                            " -c:v libx264 -pix_fmt yuv420p -crf 18 -vf 'pad=ceil(iw/2)*2:ceil(ih/2)*2' " +
                            shellQuote(tmp.string());
    // ffmpeg's exit status is not trusted alone: on a full disk it reports "Error writing
    // trailer ... No space left on device" and exits 0 with a broken file. Its messages come
    // back through a pipe (a log beside the movie would be lost on that full disk). Anything it
    // says at -loglevel error, an empty file, or a movie that does not decode to every frame
    // (ffprobe, or ffmpeg itself without it) fails the step, and the temporary goes.
    const Captured made = runCaptured(cmd);
    std::error_code ec;
    // SIGINT/SIGTERM while ffmpeg ran: no movie is kept, and the run ends as interrupted (main's
    // handler: exit 130), not with "wrote the preview movie".
    if (cancelRequested()) {
        fs::remove(tmp, ec);
        throw RuntimeError("interrupted while ffmpeg made " + moviePath.string());
    }
    const int frames = last - first + 1;
    std::string problem;
    if (!libraryMessage(made.output).empty())
        problem = causeOf(made.output) + (made.status != 0 ? "; exit status " + std::to_string(made.status) : "");
    else if (made.status != 0)
        problem = "exit status " + std::to_string(made.status);
    else if (!(fs::file_size(tmp, ec) > 0) || ec)
        problem = "it wrote no movie";
    if (problem.empty()) {
        const Decoded d = decodeMovie(tmp);
        if (d.frames != frames)
            problem = "the movie decodes to " + (d.frames == 0 ? std::string("no") : std::to_string(d.frames)) +
                      " frames of " + std::to_string(frames) +
                      (d.said.empty() ? "" : ": " + libraryMessage(d.said)) +
                      (fs::space(tmp.parent_path(), ec).available < (std::uintmax_t(1) << 20) && !ec
                           ? "; the disk is full"
                           : "");
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
