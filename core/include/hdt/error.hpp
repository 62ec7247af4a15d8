// One exception type for everything the library refuses, with a category the
// CLI turns into its exit code and the VTK filter into vtkErrorMacro text.
#pragma once

#include <stdexcept>
#include <string>

namespace hdt {

enum class ErrorKind {
  InvalidArgument, // a bad option (resolution, sizes, ...): CLI exit 2
  BadInput,        // unreadable, corrupt or unusable mesh / .hdt file: CLI exit 3
  OutOfResources,  // memory estimate too large, allocation or device failure: CLI exit 4
  Aborted,         // the caller asked to stop
  OutputFailed,    // an output file cannot be created or written: CLI exit 5
};

class Error : public std::runtime_error {
public:
  Error(ErrorKind kind, const std::string& message) : std::runtime_error(message), kind_(kind) {}
  ErrorKind kind() const noexcept { return kind_; }

private:
  ErrorKind kind_;
};

} // namespace hdt
