#pragma once

#include <stdexcept>

namespace atrium {

// A failure to report in one line and exit 1 (no device, no display, unreadable model...).
class Error : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

} // namespace atrium
