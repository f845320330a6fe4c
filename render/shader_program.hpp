#pragma once
/// @file shader_program.hpp
/// @brief (internal to render/) A GLSL program built from two files of the shader folder.
/// No GL headers here: names are plain unsigned ints (GLuint).

#include <string>

namespace dgv::render {

class ShaderProgram {
public:
    ShaderProgram() = default;
    /// Reads `dir`/`vertexFile` and `dir`/`fragmentFile`, compiles and links them. When
    /// `fragmentPrelude` is given, that file's text is inserted after the fragment shader's
    /// #version line (GLSL has no #include); a #line directive keeps the log's line numbers.
    /// `defines` (e.g. "#define DGV_SHADOWS 0\n") goes after the #version line (before the
    /// prelude, if any), for variants.
    /// RuntimeError naming the file and quoting the compiler or linker log on failure.
    ShaderProgram(const std::string& dir, const std::string& vertexFile, const std::string& fragmentFile,
                  const std::string& fragmentPrelude = "", const std::string& defines = "");
    ~ShaderProgram();
    ShaderProgram(ShaderProgram&& other) noexcept;
    ShaderProgram& operator=(ShaderProgram&& other) noexcept;
    ShaderProgram(const ShaderProgram&) = delete;
    ShaderProgram& operator=(const ShaderProgram&) = delete;

    unsigned id() const { return mId; }
    /// Uniform location by name (-1 when the linker dropped it).
    int uniform(const char* name) const;

private:
    unsigned mId = 0;
};

/// Reads a whole text file; RuntimeError naming it when it cannot be read.
std::string readShaderFile(const std::string& path);

}  // namespace dgv::render
