#pragma once

// The proxy around the links: accepts clients on --listen, connects each to --connect, and runs a
// ShapedLink per direction per connection (the layer opens one connection per VkDevice; each gets
// links of its own, as each would get its own TCP flow on a real network, minus the sharing of the
// medium: see docs/measuring.md).

#include "link_options.h"

namespace splitvk::link {

// Runs until SIGINT or SIGTERM; returns the process exit status. Logs one line at start
// ("listening on HOST:PORT ..."), one per connection at open and at close, one at exit.
int run_proxy(const LinkOptions &options);

} // namespace splitvk::link
