#pragma once
// What a plan says: the text table, the JSON document (schema in docs/plan.md) and the one-line
// failure, from the PlanResult the search (pipeline/plan.h) gave.
#include <string>

#include "pipeline/plan.h"

namespace spectex {

// The text table and the JSON document of a plan.
std::string plan_table(const PlanSpec& spec, const PlanResult& r);
std::string plan_json(const PlanSpec& spec, const PlanResult& r);
// "no candidate grid meets 0.5 ΔE00 under every light: the best is 380:780:1, 0.73 under FL11"
std::string plan_failure(const PlanSpec& spec, const PlanResult& r);

}  // namespace spectex
