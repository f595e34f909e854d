#pragma once
// verify's JSON record: one object per file (JSON Lines, schema_version 2, documented in
// docs/verify.md), built in pipeline/ as bake's records and plan's documents are; cli/ prints it.
#include <string>
#include <vector>

#include "pipeline/verify.h"

namespace spectex {

// The record of a file that was measured: its report, the gates `t` asked for and the ones it
// failed ("result": "ok", "failed" or "stale").
std::string verify_json(const VerifyReport& r, const VerifyGates& t,
                        const std::vector<std::string>& failures);
// The record of a file that could not be verified: its error, which is also its one failure, and
// the warnings given before it.
std::string verify_error_json(const std::string& file, const std::string& error,
                              const std::vector<std::string>& warnings);

}  // namespace spectex
