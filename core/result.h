// Result<T>: a value or the reason there is none, the one way bad input is
// reported (bugs are VSL_CHECKs, check.h; runtime conditions go to the log).
// The message names the file, the element and the valid range:
//   "scene.gltf: material 'steel': roughness must be in [0,1] (got 1.7)".
//
//   Result<Image> load(const std::string& path) {
//     if (...) return Error(path + ": not an EXR file");
//     return image;
//   }
//   Result<Image> r = load(p);
//   if (!r) return fail(r.error());
//   use(*r);
//
// Result<void> is success or an error; a default-constructed one is success.
// value() on an error is a bug (VSL_CHECK aborts); error() is "" on success.
// pbrt-v4 and tev (both return a value or throw/print a message) are the model;
// this is a small std::expected<T, std::string>.
#pragma once

#include <optional>
#include <string>
#include <utility>

#include "core/check.h"

namespace vsl {

// The failure half of a Result: converts to any Result<T>.
struct Error {
  std::string message;
  explicit Error(std::string m) : message(std::move(m)) {}
};

template <typename T>
class [[nodiscard]] Result {
 public:
  Result(T value) : value_(std::move(value)) {}  // NOLINT: implicit, so `return value;` works
  Result(Error e) : error_(std::move(e.message)) {}
  static Result failure(std::string message) { return Result(Error(std::move(message))); }

  bool ok() const { return value_.has_value(); }
  explicit operator bool() const { return ok(); }

  T& value() & {
    VSL_CHECK(ok());
    return *value_;
  }
  const T& value() const& {
    VSL_CHECK(ok());
    return *value_;
  }
  T&& value() && {
    VSL_CHECK(ok());
    return std::move(*value_);
  }
  T& operator*() & { return value(); }
  const T& operator*() const& { return value(); }
  T&& operator*() && { return std::move(*this).value(); }
  T* operator->() { return &value(); }
  const T* operator->() const { return &value(); }
  // The value, or `fallback` on an error.
  T valueOr(T fallback) const& { return ok() ? *value_ : std::move(fallback); }

  // The message of a failure; "" on success.
  const std::string& error() const { return error_; }

 private:
  std::optional<T> value_;
  std::string error_;
};

template <>
class [[nodiscard]] Result<void> {
 public:
  Result() = default;  // success
  Result(Error e) : ok_(false), error_(std::move(e.message)) {}
  static Result success() { return {}; }
  static Result failure(std::string message) { return Result(Error(std::move(message))); }

  bool ok() const { return ok_; }
  explicit operator bool() const { return ok_; }
  const std::string& error() const { return error_; }

 private:
  bool ok_ = true;
  std::string error_;
};

}  // namespace vsl
