#pragma once
// dgv render's output checks: the output folder can be a folder (checked before anything is
// built), and --resume's test of whether a frame already on disk is complete.

#include "base/image.hpp"

#include <string>

namespace dgv::app {

/// True when `program` is an executable file in a folder of $PATH.
bool onPath(const std::string& program);
/// `s` in single quotes for a POSIX shell (a ' inside becomes '\'').
std::string shellQuote(const std::string& s);
/// <dir>/<name>.####.<extension>: frame `frame`'s file.
std::string framePath(const std::string& dir, const std::string& name, int frame,
                      const std::string& extension = "png");

/// InputError (`input`: `where`: ...) when `dir`, or the nearest part of it that exists, is not
/// a folder (e.g. --out names a file): bad input, found before any work is done.
void checkOutputFolder(const std::string& dir, const std::string& input, const std::string& where);

/// Removes the temporaries that a killed run of this host left in the output folder and its
/// vdb/, mesh/ and state/ folders (io/atomic_file.hpp, removeStaleTemporaries), with one line
/// saying how many when there were any.
void removeStaleOutputTemporaries(const std::string& dir);

/// --resume: true when `path` holds a complete frame `frame` of `width` x `height` of this
/// version of the scene: a PNG that decodes in full (a truncated or corrupt file does not), or an
/// EXR (by its extension) whose seal holds and whose every scanline reads (io/exr.hpp), whose
/// dgv:frame text is `frame` and whose dgv:key text is `key` (io/state_file.hpp, sceneFrameKey:
/// a frame of an earlier version of the scene, or of another bit depth, is not kept). A file that
/// exists but fails any of this is not trusted: the frame is rendered again. `image`, when
/// given, receives the decoded frame (for the contact sheet).
/// With `anyRenderer`, `key` is the scene's key alone (io/state_file.hpp, sceneFrameKey) and the
/// frame may come from any GL renderer (its dgv:key is that key, a space and the renderer's name):
/// what a farm task on whichever node wrote (dgv farm status).
bool frameIsComplete(const std::string& path, int frame, int width, int height, const std::string& key,
                     Image* image = nullptr, bool anyRenderer = false);

}  // namespace dgv::app
