#pragma once
// Small result type of the per-message path: a value, or a Planet status with a precise message.
// Control-plane code (constructors, start-up) throws instead.

#include <optional>
#include <string>
#include <utility>

#include "planet.pb.h"

namespace urs::camus_server {

struct Error {
  planet::Status status = planet::INTERNAL;
  std::string message;
};

inline Error make_error(planet::Status status, std::string message) { return Error{status, std::move(message)}; }

// Stands in for "no value" in Result<Done>.
struct Done {};

template <class T>
class Result {
 public:
  Result(T value) : value_(std::move(value)) {}      // NOLINT(google-explicit-constructor)
  Result(Error error) : error_(std::move(error)) {}  // NOLINT(google-explicit-constructor)

  bool ok() const { return value_.has_value(); }
  const T& value() const& { return *value_; }
  T& value() & { return *value_; }
  T&& value() && { return std::move(*value_); }
  const T* operator->() const { return &*value_; }
  T* operator->() { return &*value_; }

  const Error& error() const { return error_; }
  planet::Status status() const { return ok() ? planet::OK : error_.status; }
  const std::string& message() const { return error_.message; }

 private:
  std::optional<T> value_;
  Error error_;
};

}  // namespace urs::camus_server
