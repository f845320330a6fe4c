// base/errors.hpp: a library's message as one short readable line.
#include "base/errors.hpp"

#include <catch2/catch.hpp>

#include <string>

using namespace dgv;

TEST_CASE("errors: a library's message becomes one short readable line", "[base][errors]") {
    // A message that echoes 22,000 bytes of a damaged file: cut to 200 characters and "...",
    // its control bytes shown as '?'.
    std::string echoed = "Unregistered grid type ";
    for (int i = 0; i < 22000; ++i) echoed += static_cast<char>(i % 7 == 0 ? 1 : 'a' + i % 26);
    const std::string cut = libraryMessage(echoed);
    CHECK(cut.size() == 203);
    CHECK(cut.rfind("Unregistered grid type ", 0) == 0);
    CHECK(cut.substr(200) == "...");
    CHECK(cut.find('\x01') == std::string::npos);
    CHECK(cut.find('?') != std::string::npos);
    // Its first non-blank line; a short one whole.
    CHECK(libraryMessage("\n  \nExpected to decompress 1216 bytes\nstack: ...") == "Expected to decompress 1216 bytes");
    CHECK(libraryMessage("no such grid") == "no such grid");
    CHECK(libraryMessage(std::string(250, 'x'), 10) == "xxxxxxxxxx...");
}
