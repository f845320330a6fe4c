#pragma once
// The preview movie of a render (dgv render --movie): <out>/<name>.mp4, H.264, made by ffmpeg from
// the frames <out>/<name>.####.png of `first`..`last`.

#include "sim/scene.hpp"

#include <string>

namespace dgv::app {

/// Makes the movie through a temporary in the output folder, renamed when ffmpeg succeeded, said
/// nothing at -loglevel error (its messages come back through a pipe, never a file beside the
/// movie), wrote a non-empty file and a movie that decodes to every frame (ffprobe, or ffmpeg
/// itself when ffprobe is missing); otherwise removes the temporary and throws RuntimeError
/// naming the movie and the cause (a full disk and a missing encoder by name; "the frames are
/// complete"). SIGINT/SIGTERM while ffmpeg runs: no movie,
/// RuntimeError "interrupted". Returns the movie's path. ffmpeg must be on PATH.
std::string writePreviewMovie(const SceneDesc& scene, int first, int last);

}  // namespace dgv::app
