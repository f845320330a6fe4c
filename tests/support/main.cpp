// dgv_tests entry point: Catch2 with floating-point traps on, so a NaN or an overflow fails
// at the operation that makes it (libigl, Jolt). Tests that call into third-party code that
// computes with infinities on purpose (Mesa, assimp) wrap it in dgv::test::FpTrapsOff.
#define CATCH_CONFIG_RUNNER
#include <catch2/catch.hpp>

#include "support/helpers.hpp"

int main(int argc, char* argv[]) {
    dgv::test::enableFpTraps();
    return Catch::Session().run(argc, argv);
}
