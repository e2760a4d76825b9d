// Assertions for invariants (bugs, not bad input: bad input gets a Result,
// result.h). A failed check prints file:line, the expression and, for the
// comparisons, both operands, then aborts:
//
//   core/film.cpp:22: VSL_CHECK_LT(x, width_) failed: 640 vs 512
//
// VSL_CHECK* are active in every build type: they guard invariants and cost
// one comparison. VSL_DCHECK* compile to nothing unless NDEBUG is undefined
// (Debug builds); use them only in hot loops. Operands are evaluated exactly
// once (DCHECK operands not at all in release builds). An operand printed must
// be streamable to std::ostream. pbrt-v4's util/check.h is the model.
#pragma once

#include <sstream>
#include <string>

namespace vsl::detail {

// Prints "file:line: what failed[: detail]" to stderr and aborts. Never returns.
[[noreturn]] void checkFailed(const char* file, int line, const char* what, const std::string& detail);

template <typename A, typename B>
[[noreturn]] void checkOpFailed(const char* file, int line, const char* what, const A& a, const B& b) {
  std::ostringstream os;
  os.precision(17);
  os << a << " vs " << b;
  checkFailed(file, line, what, os.str());
}

}  // namespace vsl::detail

#define VSL_CHECK(cond)                                                                  \
  do {                                                                                   \
    if (!(cond)) [[unlikely]]                                                            \
      ::vsl::detail::checkFailed(__FILE__, __LINE__, "VSL_CHECK(" #cond ") failed", ""); \
  } while (false)

#define VSL_CHECK_OP_(name, op, a, b)                                                                           \
  do {                                                                                                          \
    const auto& vslCheckA_ = (a);                                                                               \
    const auto& vslCheckB_ = (b);                                                                               \
    if (!(vslCheckA_ op vslCheckB_)) [[unlikely]]                                                               \
      ::vsl::detail::checkOpFailed(__FILE__, __LINE__, name "(" #a ", " #b ") failed", vslCheckA_, vslCheckB_); \
  } while (false)

#define VSL_CHECK_EQ(a, b) VSL_CHECK_OP_("VSL_CHECK_EQ", ==, a, b)
#define VSL_CHECK_NE(a, b) VSL_CHECK_OP_("VSL_CHECK_NE", !=, a, b)
#define VSL_CHECK_LT(a, b) VSL_CHECK_OP_("VSL_CHECK_LT", <, a, b)
#define VSL_CHECK_LE(a, b) VSL_CHECK_OP_("VSL_CHECK_LE", <=, a, b)
#define VSL_CHECK_GT(a, b) VSL_CHECK_OP_("VSL_CHECK_GT", >, a, b)
#define VSL_CHECK_GE(a, b) VSL_CHECK_OP_("VSL_CHECK_GE", >=, a, b)

#ifndef NDEBUG
#define VSL_DCHECK(cond) VSL_CHECK(cond)
#define VSL_DCHECK_EQ(a, b) VSL_CHECK_EQ(a, b)
#define VSL_DCHECK_NE(a, b) VSL_CHECK_NE(a, b)
#define VSL_DCHECK_LT(a, b) VSL_CHECK_LT(a, b)
#define VSL_DCHECK_LE(a, b) VSL_CHECK_LE(a, b)
#define VSL_DCHECK_GT(a, b) VSL_CHECK_GT(a, b)
#define VSL_DCHECK_GE(a, b) VSL_CHECK_GE(a, b)
#else
// Not evaluated, but still compiled (so they cannot rot).
#define VSL_DCHECK(cond)     \
  do {                       \
    if (false) (void)(cond); \
  } while (false)
#define VSL_DCHECK_OP_(a, b)         \
  do {                               \
    if (false) (void)(a), (void)(b); \
  } while (false)
#define VSL_DCHECK_EQ(a, b) VSL_DCHECK_OP_(a, b)
#define VSL_DCHECK_NE(a, b) VSL_DCHECK_OP_(a, b)
#define VSL_DCHECK_LT(a, b) VSL_DCHECK_OP_(a, b)
#define VSL_DCHECK_LE(a, b) VSL_DCHECK_OP_(a, b)
#define VSL_DCHECK_GT(a, b) VSL_DCHECK_OP_(a, b)
#define VSL_DCHECK_GE(a, b) VSL_DCHECK_OP_(a, b)
#endif
