#pragma once
/// @file check.hpp
/// @brief Checks for programming errors (bugs), not for bad input. A failed check prints the
/// expression, both operands and file:line, then aborts. Bad input throws InputError
/// (errors.hpp); numerical trouble is a returned report.

#include <sstream>
#include <string>

namespace dgv::detail {
[[noreturn]] void checkFailed(const char* file, int line, const std::string& message);

template <typename A, typename B>
[[noreturn]] void checkOpFailed(const char* file, int line, const char* expr, const A& a, const B& b) {
    std::ostringstream os;
    os << "check failed: " << expr << " with lhs = " << a << ", rhs = " << b;
    checkFailed(file, line, os.str());
}
}  // namespace dgv::detail

#define DGV_CHECK(cond)                                                                      \
    do {                                                                                     \
        if (!(cond)) ::dgv::detail::checkFailed(__FILE__, __LINE__, "check failed: " #cond); \
    } while (false)

#define DGV_CHECK_OP_(a, b, op)                                                                                   \
    do {                                                                                                          \
        const auto& dgvA_ = (a);                                                                                  \
        const auto& dgvB_ = (b);                                                                                  \
        if (!(dgvA_ op dgvB_)) ::dgv::detail::checkOpFailed(__FILE__, __LINE__, #a " " #op " " #b, dgvA_, dgvB_); \
    } while (false)

#define DGV_CHECK_EQ(a, b) DGV_CHECK_OP_(a, b, ==)
#define DGV_CHECK_NE(a, b) DGV_CHECK_OP_(a, b, !=)
#define DGV_CHECK_LT(a, b) DGV_CHECK_OP_(a, b, <)
#define DGV_CHECK_LE(a, b) DGV_CHECK_OP_(a, b, <=)
#define DGV_CHECK_GT(a, b) DGV_CHECK_OP_(a, b, >)
#define DGV_CHECK_GE(a, b) DGV_CHECK_OP_(a, b, >=)
