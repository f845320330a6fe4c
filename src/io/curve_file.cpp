#include "io/curve_file.hpp"

#include "base/errors.hpp"
#include "io/atomic_file.hpp"
#include "io/read_file.hpp"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>

namespace dgv {

std::vector<Vec3> parseCurveText(const std::string& text, const std::string& name) {
    std::vector<Vec3> curve;
    std::istringstream in(text);
    std::string line;
    int lineNo = 0;
    while (std::getline(in, line)) {
        ++lineNo;
        const std::string where = "line " + std::to_string(lineNo);
        const std::size_t hash = line.find('#');
        if (hash != std::string::npos) line.resize(hash);
        if (!line.empty() && line.back() == '\r') line.pop_back();
        double v[3];
        int count = 0;
        const char* p = line.c_str();
        while (true) {
            while (*p == ' ' || *p == '\t' || *p == ',' || *p == '\r') ++p;
            if (!*p) break;
            char* endp = nullptr;
            errno = 0;
            const double x = std::strtod(p, &endp);
            if (endp == p) {
                std::string bad(p);
                if (bad.size() > 24) bad = bad.substr(0, 24) + "...";
                throw InputError(name, where, "expected three numbers \"x y z\", got \"" + bad + "\"");
            }
            if (std::isnan(x) || std::isinf(x) || (errno == ERANGE && std::abs(x) > 1))
                throw InputError(name, where, "coordinate " + std::to_string(count + 1) + " is not a finite number");
            if (count < 3) v[count] = x;
            ++count;
            p = endp;
        }
        if (count == 0) continue;
        if (count != 3) throw InputError(name, where, "expected three numbers \"x y z\", got " + std::to_string(count));
        curve.emplace_back(v[0], v[1], v[2]);
    }
    if (curve.size() < 3)
        throw InputError(name, "", "a closed curve needs at least 3 vertices, found " + std::to_string(curve.size()));
    return curve;
}

std::vector<Vec3> readCurveFile(const std::filesystem::path& path) {
    constexpr std::uintmax_t kMaxCurveBytes = 256u << 20;  // ~5M vertices of text
    return parseCurveText(readInputFile(path, "curve file", kMaxCurveBytes), path.string());
}

void writeCurveFile(const std::filesystem::path& path, const std::vector<Vec3>& curve, const std::string& comment) {
    std::string out;
    if (!comment.empty()) out += "# " + comment + "\n";
    char buf[96];
    for (const Vec3& p : curve) {
        std::snprintf(buf, sizeof buf, "%.17g %.17g %.17g\n", p.x(), p.y(), p.z());
        out += buf;
    }
    writeTextAtomically(path, out);
}

}  // namespace dgv
