// Every citation of a docs/ section in the project's code and docs, `docs/X.md, "Section"` (or
// `docs/X.md ("Section")`), names a section that exists: a heading of docs/X.md, or a bold
// paragraph title in it, that is the cited text or starts with it (a citation ending in "..."
// cites the start of one). Comments that pointed at sections which had moved or been renamed
// sent a reader nowhere.
#include "support/helpers.hpp"

#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

namespace fs = std::filesystem;

namespace {

std::string readText(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

/// The headings and bold paragraph titles of a markdown file.
std::set<std::string> sectionsOf(const std::string& text) {
    std::set<std::string> out;
    std::istringstream in(text);
    static const std::regex heading(R"(^#+\s+(.*\S)\s*$)"), bold(R"(\*\*([^*]+?)\*\*)");
    for (std::string line; std::getline(in, line);) {
        std::smatch m;
        if (std::regex_match(line, m, heading)) out.insert(m[1]);
        for (auto it = std::sregex_iterator(line.begin(), line.end(), bold); it != std::sregex_iterator(); ++it) {
            std::string t = (*it)[1];
            while (!t.empty() && (t.back() == '.' || t.back() == ' ')) t.pop_back();
            out.insert(t);
        }
    }
    return out;
}

}  // namespace

TEST_CASE("docs: every cited docs section exists", "[docs]") {
    const fs::path root = dgv::test::sourcePath(".");
    const std::set<std::string> extensions = {".cpp", ".hpp", ".inc", ".md", ".sh", ".cmake", ".txt",
                                              ".glsl", ".vert", ".frag"};
    std::vector<fs::path> files = {root / "README.md"};
    for (const char* dir : {"src", "render", "shaders", "tests", "docs", "scenes", "scripts"})
        for (const auto& e : fs::recursive_directory_iterator(root / dir))
            if (e.is_regular_file() && extensions.count(e.path().extension().string())) files.push_back(e.path());
    static const std::regex citation(R"re((docs/[a-z_/-]+\.md)[,:]?\s*\(?"([^"]+)")re");
    static const std::regex wrap(R"(\s*\n\s*(///|//|#)?\s*)");
    std::map<std::string, std::set<std::string>> sections;
    int cited = 0;
    std::vector<std::string> broken;
    for (const fs::path& f : files) {
        const std::string text = readText(f);
        for (auto it = std::sregex_iterator(text.begin(), text.end(), citation); it != std::sregex_iterator(); ++it) {
            const std::string doc = (*it)[1];
            std::string section = std::regex_replace(std::string((*it)[2]), wrap, " ");
            if (section.size() > 3 && section.compare(section.size() - 3, 3, "...") == 0)
                section = section.substr(0, section.find_last_not_of(" .", section.size() - 4) + 1);
            ++cited;
            if (!sections.count(doc)) {
                const fs::path p = root / doc;
                sections[doc] = fs::exists(p) ? sectionsOf(readText(p)) : std::set<std::string>{};
            }
            bool found = false;
            for (const std::string& s : sections[doc])
                found = found || s.rfind(section, 0) == 0;  // the title, or its start
            if (!found) broken.push_back(fs::relative(f, root).string() + " cites " + doc + ", \"" + section + "\"");
        }
    }
    std::string list;
    for (const std::string& b : broken) list += "\n  " + b;
    INFO(cited << " citations; broken:" << list);
    CHECK(cited > 200);
    CHECK(broken.empty());
}

TEST_CASE("docs: the equation table's test files exist", "[docs]") {
    // docs/math.md, "Equation → file": each row's tests column lists `tests/dir/test_x.cpp` and
    // then `test_y.cpp` of the same folder.
    const fs::path root = dgv::test::sourcePath(".");
    const std::string math = readText(root / "docs" / "math.md");
    const std::size_t start = math.find("| equations | what | where | tests | status |");
    REQUIRE(start != std::string::npos);
    std::istringstream rows(math.substr(start, math.find("\n\n", start) - start));
    static const std::regex path(R"(`([^`]+\.cpp)`)");
    int rowsRead = 0, files = 0;
    std::vector<std::string> missing;
    for (std::string row; std::getline(rows, row);) {
        if (row.rfind("| equations", 0) == 0 || row.rfind("|---", 0) == 0) continue;
        std::vector<std::string> cells;
        for (std::size_t at = 1, bar; (bar = row.find(" | ", at)) != std::string::npos; at = bar + 3)
            cells.push_back(row.substr(at, bar - at));
        REQUIRE(cells.size() == 4);  // equations, what, where, tests (status ends the row)
        ++rowsRead;
        std::string folder;
        for (auto it = std::sregex_iterator(cells[3].begin(), cells[3].end(), path); it != std::sregex_iterator();
             ++it) {
            std::string file = (*it)[1];
            if (file.rfind("tests/", 0) == 0)
                folder = file.substr(0, file.rfind('/') + 1);
            else
                file = folder + file;
            ++files;
            if (!fs::exists(root / file)) missing.push_back(file);
        }
    }
    std::string list;
    for (const std::string& m : missing) list += " " + m;
    INFO("missing:" << list);
    CHECK(rowsRead >= 10);
    CHECK(files >= rowsRead);
    CHECK(missing.empty());
}
