// Scenario configurations as JSON files (share/sim/*.json), read with nlohmann-json.
//
// A file is one object whose keys override the defaults of ScenarioConfig (the settings and their
// keys are the rows of scenario_schema.h); every key is optional,
// unknown keys are errors (they are typos), and values must have the right JSON type:
//   seed (integer), mode ("sliding-window" | "whole"), window, weight_scale, solve (bool),
//   camera        {height, width, fx, fy, cx, cy}
//   scene         {min: [x,y,z], max: [x,y,z], boxes: [{min: [..], max: [..]}, ...]}
//   trajectory    {type ("line" | "loop" | "explore-return"), keyframes, step, yaw_amplitude,
//                  loop_center: [x,y,z], loop_radius, keyframes_per_lap}
//   edges         {radius, overlap_threshold, max_overlap_edges, candidate_distance}
//   weights       {distribution ("uniform" | "beta" | "constant"), min, max, alpha, beta, value,
//                  zero_fraction}
//   noise         {model ("white" | "correlated"), correlation_length_px, amplitude, affine_px,
//                  field_px, field_length_px, outlier_fraction, outlier_factor}
//   gauge         {type ("two-pose" | "minimal"), sigma_rot, sigma_trans}
//   initial_perturbation {translation, rotation, inverse_depth}
//   solver        {max_iterations, initial_lambda, max_lambda, function_tolerance,
//                  gradient_tolerance, step_tolerance, min_inverse_depth}
//   time          {frame_interval, fps, start_time}
// Errors throw dbacov::InputError naming the file and the key path ("share/sim/x.json: key
// 'noise.model': expected a string"); the configuration's values are checked afterwards by
// ScenarioConfig::validate (std::invalid_argument).
#pragma once

#include <string>

#include "dbacov/sim/scenario.h"

namespace dbacov::sim {

/// Applies the JSON text (an object) to `config`; `source` names it in errors.
void applyScenarioJson(const std::string& text, const std::string& source, ScenarioConfig& config);

/// Defaults overridden by the file at `path`. Throws InputError when it cannot be read.
ScenarioConfig loadScenarioConfig(const std::string& path);

/// Every setting of `config` as a JSON object (indented): what applyScenarioJson reads back into
/// the same configuration.
std::string scenarioConfigToJson(const ScenarioConfig& config);

}  // namespace dbacov::sim
