#pragma once
// dfb-client bench: edit-to-frame latency percentiles as one editing client sees them, with other
// clients watching (docs/operations.md). A load generator for many editors is dfb-load-bench.

#include "Client.h"

#include <string>

namespace dfb::cli {

/// Runs `edits` timed edits (after `warmup` untimed ones) of `lightName` (empty: the first light)
/// with `clients` - 1 watching clients; prints the percentiles; returns the exit code.
int bench(Client& cl, int edits, int clients, const std::string& lightName, int warmup);

} // namespace dfb::cli
