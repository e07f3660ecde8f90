// Errors that cross the native boundary. Every failure names the place it
// happened (bone and frame, file and line, curve and key), so the message that
// reaches the user can be acted on without a debugger.
#pragma once

#include <stdexcept>
#include <string>

namespace motionkit {

// Thrown by Run() wrappers and readers; the Python bindings translate it into
// motionkit.MotionKitError (a ValueError), never a crash.
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Result of a job's Validate(): cheap to return, carries the reason on failure.
class Status {
 public:
  static Status Ok() { return Status(); }
  static Status Fail(std::string message) { return Status(std::move(message)); }

  bool ok() const { return !failed_; }
  explicit operator bool() const { return ok(); }
  const std::string& message() const { return message_; }

  // Raises the failure as an Error; used by callers that prefer exceptions.
  void ThrowIfFailed() const {
    if (failed_) throw Error(message_);
  }

 private:
  Status() = default;
  explicit Status(std::string message) : failed_(true), message_(std::move(message)) {}

  bool failed_ = false;
  std::string message_;
};

}  // namespace motionkit
