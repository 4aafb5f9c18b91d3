// The parts of experiment parsing that make conditions (tools/harness/experiment_grid.cc): grid
// values, sampled parameters, and each condition's parameters and render options. Used by
// experiment.cc; the public API (ExpandItems, LevelLabels, MixSeed, ...) is in experiment.h.
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "tools/harness/experiment.h"

namespace turbid {

// A name that may become a file or folder name: 1-64 characters of [A-Za-z0-9_.-], not "." or
// "..". (Scene names and method labels also refuse '.'.)
bool IsSafeName(const std::string& name);

// Axis names and level labels reach the tables (CSV, Markdown), the plots and `regress` as text:
// throws Error(file, ...) for a control character (a newline above all) in `text`.
void CheckLabelText(const std::string& file, const std::string& what, const std::string& text);

// The number `value` holds; throws Error(file, ...) when it is not a finite number.
double FiniteNumber(const nlohmann::json& value, const std::string& file, const std::string& what);

// Grid values: an array, or {"linspace": [lo, hi, n]} / {"logspace": [lo, hi, n]}, or a named
// axis ("@name": [{path: value, "label": ...}, ...]).
std::vector<nlohmann::json> GridValues(const nlohmann::json& spec, const std::string& file,
                                       const std::string& path);

// One "samples.params" entry: {"uniform"|"log_uniform"|"int_uniform": [lo, hi]} or
// {"choice": [...]}.
SampledParam ParseSampled(const std::string& path, const nlohmann::json& spec,
                          const std::string& file);

// The distribution a sampler spec names — {"uniform"|"log_uniform"|"int_uniform": [lo, hi]} or
// {"choice": [...]} — checked (lo <= hi, finite, log_uniform lo > 0, int_uniform integer bounds);
// errors are Error(file, what + ...). The one reading of sampler specs: a sweep's "samples" and
// generate's "random" (and turbid.data's DegradeTransform) share it.
SampledParam ParseDistribution(const nlohmann::json& spec, const std::string& file,
                               const std::string& what);
// A draw of `param` at u in [0, 1).
nlohmann::json DrawDistribution(const SampledParam& param, double u);

// Parameters of one condition (grid point x sample draw), in a fixed order.
nlohmann::json ConditionParams(const Experiment& experiment, int condition);

// The base render options with a condition's parameters applied.
nlohmann::json ConditionRenderOptions(const Experiment& experiment, const nlohmann::json& params);

}  // namespace turbid
