#include "render/shader_program.hpp"

#include "base/errors.hpp"

#define GL_GLEXT_PROTOTYPES 1
#include <GL/glcorearb.h>

#include <fstream>
#include <sstream>
#include <utility>

namespace dgv::render {

namespace {

std::string shaderLog(GLuint shader) {
    GLint len = 0;
    glGetShaderiv(shader, GL_INFO_LOG_LENGTH, &len);
    std::string log(static_cast<std::size_t>(len > 0 ? len : 1), '\0');
    glGetShaderInfoLog(shader, len, nullptr, log.data());
    return log.c_str();
}

std::string programLog(GLuint program) {
    GLint len = 0;
    glGetProgramiv(program, GL_INFO_LOG_LENGTH, &len);
    std::string log(static_cast<std::size_t>(len > 0 ? len : 1), '\0');
    glGetProgramInfoLog(program, len, nullptr, log.data());
    return log.c_str();
}

GLuint compile(GLenum type, const std::string& path, const std::string& preludePath = "",
               const std::string& defines = "") {
    std::string source = readShaderFile(path);
    if (preludePath.empty() && !defines.empty()) {
        const std::size_t eol = source.find('\n');
        if (source.compare(0, 8, "#version") != 0 || eol == std::string::npos) {
            throw RuntimeError("shader " + path + ": the first line must be the #version line");
        }
        source = source.substr(0, eol + 1) + defines + "#line 2 0\n" + source.substr(eol + 1);
    } else if (!preludePath.empty()) {
        const std::size_t eol = source.find('\n');
        if (source.compare(0, 8, "#version") != 0 || eol == std::string::npos) {
            throw RuntimeError("shader " + path + ": the first line must be the #version line");
        }
        source = source.substr(0, eol + 1) + defines + "#line 1 1\n" + readShaderFile(preludePath) + "\n#line 2 0\n" +
                 source.substr(eol + 1);
    }
    GLuint shader = glCreateShader(type);
    const char* text = source.c_str();
    glShaderSource(shader, 1, &text, nullptr);
    glCompileShader(shader);
    GLint ok = GL_FALSE;
    glGetShaderiv(shader, GL_COMPILE_STATUS, &ok);
    if (!ok) {
        const std::string log = shaderLog(shader);
        glDeleteShader(shader);
        throw RuntimeError("shader " + path + " does not compile" +
                           (preludePath.empty() ? std::string() : " (source 1 in the log is " + preludePath + ")") +
                           ":\n" + log);
    }
    return shader;
}

}  // namespace

std::string readShaderFile(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw RuntimeError("shader " + path + ": cannot be read");
    std::ostringstream ss;
    ss << in.rdbuf();
    if (in.bad()) throw RuntimeError("shader " + path + ": read error");
    return ss.str();
}

ShaderProgram::ShaderProgram(const std::string& dir, const std::string& vertexFile, const std::string& fragmentFile,
                             const std::string& fragmentPrelude, const std::string& defines) {
    const std::string vpath = dir + "/" + vertexFile;
    const std::string fpath = dir + "/" + fragmentFile;
    GLuint vs = compile(GL_VERTEX_SHADER, vpath);
    GLuint fs = 0;
    try {
        fs = compile(GL_FRAGMENT_SHADER, fpath, fragmentPrelude.empty() ? std::string() : dir + "/" + fragmentPrelude,
                     defines);
    } catch (...) {
        glDeleteShader(vs);
        throw;
    }
    mId = glCreateProgram();
    glAttachShader(mId, vs);
    glAttachShader(mId, fs);
    glLinkProgram(mId);
    glDeleteShader(vs);
    glDeleteShader(fs);
    GLint ok = GL_FALSE;
    glGetProgramiv(mId, GL_LINK_STATUS, &ok);
    if (!ok) {
        const std::string log = programLog(mId);
        glDeleteProgram(mId);
        mId = 0;
        throw RuntimeError("shader program " + vpath + " + " + fpath + " does not link:\n" + log);
    }
}

ShaderProgram::~ShaderProgram() {
    if (mId) glDeleteProgram(mId);
}

ShaderProgram::ShaderProgram(ShaderProgram&& other) noexcept : mId(std::exchange(other.mId, 0u)) {}

ShaderProgram& ShaderProgram::operator=(ShaderProgram&& other) noexcept {
    if (this != &other) {
        if (mId) glDeleteProgram(mId);
        mId = std::exchange(other.mId, 0u);
    }
    return *this;
}

int ShaderProgram::uniform(const char* name) const { return glGetUniformLocation(mId, name); }

}  // namespace dgv::render
