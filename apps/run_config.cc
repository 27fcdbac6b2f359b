#include "run_config.h"

#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <type_traits>
#include <variant>

#include <yaml-cpp/yaml.h>

#include "fsp/common/error.h"

namespace fsp::apps {

namespace {

using backend::EstimatorMode;
using backend::LandmarkType;
using backend::RobustLossOptions;
using backend::WindowBoundary;

using FieldRef =
    std::variant<int*, double*, bool*, uint32_t*, std::string*, EstimatorMode*, LandmarkType*,
                 RobustLossOptions::Type*, WindowBoundary*, std::optional<double>*>;

// Accepted numeric range of a field: lo < x (lo_open) or lo <= x, and x <= hi.
struct Range {
  double lo = -std::numeric_limits<double>::infinity();
  bool lo_open = false;
  double hi = std::numeric_limits<double>::infinity();
};
constexpr double kInf = std::numeric_limits<double>::infinity();
const Range kAny{};
const Range kPositive{0.0, true, kInf};
const Range kNonNegative{0.0, false, kInf};
const Range kAtLeastOne{1.0, false, kInf};

struct Field {
  std::string key;  // dotted path
  FieldRef ref;
  Range range;
};

// The table of every config key, bound to the members of C. The order is the order of default.yaml
// and of ToYaml. A new Options field needs one line here (and one in assets/config/default.yaml).
std::vector<Field> Fields(RunConfig& c) {
  backend::EstimatorOptions& e = c.estimator;
  frontend::FrontEndOptions& f = c.frontend;
  return {
      {"estimator.mode", &e.mode, kAny},
      {"estimator.landmarks", &e.landmarks, kAny},
      {"estimator.window_size", &e.window_size, {2.0, false, kInf}},
      {"estimator.keyframe_interval_s", &e.keyframe_interval_s, kNonNegative},
      {"estimator.keyframe_min_frames", &e.keyframe_min_frames, kNonNegative},
      {"estimator.batch_keyframe_interval_s", &e.batch_keyframe_interval_s, kNonNegative},
      {"estimator.window_max_iterations", &e.window_max_iterations, kAtLeastOne},
      {"estimator.frame_motion_only", &e.frame_motion_only, kAny},
      {"estimator.batch_solve_every", &e.batch_solve_every, kAtLeastOne},
      {"estimator.batch_max_iterations", &e.batch_max_iterations, kAtLeastOne},
      {"estimator.prior_gyro_bias_sigma", &e.prior_gyro_bias_sigma, kPositive},
      {"estimator.prior_acc_bias_sigma", &e.prior_acc_bias_sigma, kPositive},
      {"estimator.prior_log_omega_sigma", &e.prior_log_omega_sigma, kPositive},
      {"estimator.max_past_views", &e.max_past_views, kNonNegative},
      {"estimator.min_observations", &e.min_observations, kAtLeastOne},
      {"estimator.max_size_sigma_frac", &e.max_size_sigma_frac, kNonNegative},
      {"estimator.mature_views", &e.mature_views, kAtLeastOne},
      {"estimator.min_depth_m", &e.min_depth_m, kPositive},
      {"estimator.max_depth_m", &e.max_depth_m, kPositive},
      {"estimator.reinit_gate_px", &e.reinit_gate_px, kNonNegative},
      {"estimator.start_agree_px", &e.start_agree_px, kNonNegative},
      {"estimator.start_agree_gap_s", &e.start_agree_gap_s, kNonNegative},
      {"estimator.global.enabled", &e.global.enabled, kAny},
      {"estimator.global.every_keyframes", &e.global.every_keyframes, kAtLeastOne},
      {"estimator.global.max_iterations", &e.global.max_iterations, kAtLeastOne},
      {"estimator.global.final_iterations", &e.global.final_iterations, kAtLeastOne},
      {"estimator.global.function_tolerance", &e.global.function_tolerance, Range{0.0, true, 1.0}},
      {"estimator.global.boundary", &e.global.boundary, kAny},
      {"estimator.global.apply_after_keyframes", &e.global.apply_after_keyframes, kNonNegative},
      {"estimator.global.apply_after_per_keyframes", &e.global.apply_after_per_keyframes,
       kNonNegative},
      {"estimator.global.background", &e.global.background, kAny},
      {"estimator.global.max_free_keyframes", &e.global.max_free_keyframes, kNonNegative},
      {"estimator.global.loop_direct_px", &e.global.loop_direct_px, kNonNegative},
      {"estimator.global.loop_accept_px", &e.global.loop_accept_px, kNonNegative},
      {"estimator.global.budget_m", &e.global.budget_m, kNonNegative},
      {"estimator.global.budget_per_m", &e.global.budget_per_m, kNonNegative},
      {"estimator.global.budget_blind_acc", &e.global.budget_blind_acc, kNonNegative},
      {"estimator.global.budget_yaw_deg", &e.global.budget_yaw_deg, kNonNegative},
      {"estimator.global.budget_yaw_per_m", &e.global.budget_yaw_per_m, kNonNegative},
      {"estimator.zero_velocity.enabled", &e.zero_velocity.enabled, kAny},
      {"estimator.zero_velocity.max_turn_rate", &e.zero_velocity.max_turn_rate, kPositive},
      {"estimator.zero_velocity.confidence", &e.zero_velocity.confidence, Range{0.5, true, 1.0}},
      {"estimator.zero_velocity.velocity_sigma", &e.zero_velocity.velocity_sigma, kPositive},
      {"estimator.faults.max_imu_gap_s", &e.faults.max_imu_gap_s, kPositive},
      {"estimator.faults.gap_max_acc", &e.faults.gap_max_acc, kPositive},
      {"estimator.faults.gap_max_rate", &e.faults.gap_max_rate, kPositive},
      {"estimator.faults.frame_gap_s", &e.faults.frame_gap_s, kPositive},
      {"estimator.faults.blind_s", &e.faults.blind_s, kPositive},
      {"estimator.faults.max_speed", &e.faults.max_speed, kPositive},
      {"estimator.faults.max_gyro_bias", &e.faults.max_gyro_bias, kPositive},
      {"estimator.faults.max_acc_bias", &e.faults.max_acc_bias, kPositive},
      {"estimator.faults.max_jump_m", &e.faults.max_jump_m, kPositive},
      {"estimator.faults.max_view_error_px", &e.faults.max_view_error_px, kPositive},
      {"estimator.faults.restart_velocity_sigma", &e.faults.restart_velocity_sigma, kPositive},
      {"estimator.faults.restart_roll_pitch_sigma", &e.faults.restart_roll_pitch_sigma, kPositive},
      {"estimator.static_init.window_s", &e.static_init.window_s, kPositive},
      {"estimator.static_init.block_s", &e.static_init.block_s, kPositive},
      {"estimator.static_init.max_gyro_block_std", &e.static_init.max_gyro_block_std, kPositive},
      {"estimator.static_init.max_acc_block_std", &e.static_init.max_acc_block_std, kPositive},
      {"estimator.static_init.max_gravity_error", &e.static_init.max_gravity_error, kPositive},
      {"estimator.static_init.min_samples", &e.static_init.min_samples, kAtLeastOne},
      {"estimator.static_init.gravity", &e.static_init.gravity, kPositive},
      {"estimator.motion_init.enabled", &e.motion_init.enabled, kAny},
      {"estimator.motion_init.window_s", &e.motion_init.window_s, kPositive},
      {"estimator.motion_init.max_wait_s", &e.motion_init.max_wait_s, kPositive},
      {"estimator.motion_init.min_view_spacing_s", &e.motion_init.min_view_spacing_s, kNonNegative},
      {"estimator.motion_init.min_views", &e.motion_init.min_views, kAtLeastOne},
      {"estimator.motion_init.max_rotation_error_deg", &e.motion_init.max_rotation_error_deg,
       kPositive},
      {"estimator.motion_init.max_gravity_error", &e.motion_init.max_gravity_error, kPositive},
      {"estimator.motion_init_velocity_sigma", &e.motion_init_velocity_sigma, kPositive},
      {"estimator.factor.sigma_px", &e.factor.sigma_px, kPositive},
      {"estimator.factor.min_h_z", &e.factor.min_h_z, kPositive},
      {"estimator.robust.type", &e.robust.type, kAny},
      {"estimator.robust.k_sigma", &e.robust.k_sigma, kPositive},
      {"estimator.preintegration.gravity", &e.imu.gravity, kPositive},
      {"estimator.preintegration.reintegrate_gyro_bias_threshold",
       &e.imu.reintegrate_gyro_bias_threshold, kPositive},
      {"estimator.preintegration.reintegrate_acc_bias_threshold",
       &e.imu.reintegrate_acc_bias_threshold, kPositive},
      {"estimator.single_view_init.width_door_m", &e.init.width_door_m, kPositive},
      {"estimator.single_view_init.width_window_m", &e.init.width_window_m, kPositive},
      {"estimator.single_view_init.width_cabinet_m", &e.init.width_cabinet_m, kPositive},
      {"estimator.single_view_init.width_poster_m", &e.init.width_poster_m, kPositive},
      {"estimator.single_view_init.width_tag_m", &e.init.width_tag_m, kPositive},
      {"estimator.single_view_init.default_depth_m", &e.init.default_depth_m, kPositive},
      {"estimator.single_view_init.max_abs_cos", &e.init.max_abs_cos, {0.0, true, 1.0}},
      {"estimator.single_view_init.max_rms_sigma", &e.init.max_rms_sigma, kPositive},
      {"estimator.single_view_init.refine", &e.init.refine, kAny},
      {"estimator.single_view_init.max_iterations", &e.init.max_iterations, kNonNegative},
      {"estimator.single_view_init.sigma_px", &e.init.sigma_px, kPositive},
      {"estimator.single_view_init.up_sigma_rad", &e.init.up_sigma_rad, kPositive},
      {"estimator.single_view_init.min_triangle_area_px2", &e.init.min_triangle_area_px2,
       kNonNegative},
      {"imu.gyroscope_noise_density", &c.imu.gyroscope_noise_density, kPositive},
      {"imu.accelerometer_noise_density", &c.imu.accelerometer_noise_density, kPositive},
      {"imu.gyroscope_random_walk", &c.imu.gyroscope_random_walk, kPositive},
      {"imu.accelerometer_random_walk", &c.imu.accelerometer_random_walk, kPositive},
      {"frontend.gt_corners.pixel_sigma", &c.gt_corners.pixel_sigma, kNonNegative},
      {"frontend.gt_corners.seed", &c.gt_corners.seed, kAny},
      {"frontend.gt_corners.min_visible_corners", &c.gt_corners.min_visible_corners, kAny},
      {"frontend.detect_every", &f.detect_every, kNonNegative},
      {"frontend.confirm_detections", &f.confirm_detections, kNonNegative},
      {"frontend.confirm_within_frames", &f.confirm_within_frames, kAtLeastOne},
      {"frontend.replace_candidates", &f.replace_candidates, kAny},
      {"frontend.confirm_away_from_border", &f.confirm_away_from_border, kAny},
      {"frontend.reid_at_confirmation", &f.reid_at_confirmation, kAny},
      {"frontend.reid_away_from_border", &f.reid_away_from_border, kAny},
      {"frontend.detect_on_predicted_return", &f.detect_on_predicted_return, kAny},
      {"frontend.detect_skip_tracked_frac", &f.detect_skip_tracked_frac, kNonNegative},
      {"frontend.match_gate_frac", &f.match_gate_frac, kNonNegative},
      {"frontend.reid_min_similarity", &f.reid_min_similarity, kNonNegative},
      {"frontend.reid_min_margin", &f.reid_min_margin, kNonNegative},
      {"frontend.reid_gate_frac", &f.reid_gate_frac, kNonNegative},
      {"frontend.reid_min_similarity_predicted", &f.reid_min_similarity_predicted, kNonNegative},
      {"frontend.reid_reject_frac", &f.reid_reject_frac, kNonNegative},
      {"frontend.reid_map_decides", &f.reid_map_decides, kAny},
      {"frontend.reid_only_where_predicted", &f.reid_only_where_predicted, kAny},
      {"frontend.reacquire_predicted", &f.reacquire_predicted, kAny},
      {"frontend.reacquire_over_candidates", &f.reacquire_over_candidates, kAny},
      {"frontend.relearn_outline_sharper", &f.relearn_outline_sharper, kNonNegative},
      {"frontend.correct_px", &f.correct_px, kNonNegative},
      {"frontend.edge_sigma_px", &f.edge_sigma_px, kNonNegative},
      {"frontend.keypoint_sigma_px", &f.keypoint_sigma_px, kNonNegative},
      {"frontend.edge_sigma_min_motion_px", &f.edge_sigma_min_motion_px, kNonNegative},
      {"frontend.border_margin_px", &f.border_margin_px, kNonNegative},
      {"frontend.correct_tags", &f.correct_tags, kAny},
      {"frontend.tag_scan_every", &f.tag_scan_every, kNonNegative},
      {"frontend.tag_crop_margin_frac", &f.tag_crop_margin_frac, kNonNegative},
      {"frontend.first_rect_id", &f.first_rect_id, kNonNegative},
      {"frontend.min_visible_corners", &f.min_visible_corners, kAny},
      {"frontend.rect.detect_long_side", &f.rect.detect_long_side, kNonNegative},
      {"frontend.rect.texture_level", &f.rect.texture_level, kNonNegative},
      {"frontend.rect.texture_search_px", &f.rect.texture_search_px, kNonNegative},
      {"frontend.rect.texture_reach_failures_any_corner", &f.rect.texture_reach_failures_any_corner,
       kNonNegative},
      {"frontend.rect.canny_noise_multiple", &f.rect.canny_noise_multiple, kNonNegative},
      {"frontend.rect.min_edge_contrast", &f.rect.min_edge_contrast, kNonNegative},
      {"frontend.rect.canny_low_ratio", &f.rect.canny_low_ratio, kNonNegative},
      {"frontend.rect.min_segment_frac", &f.rect.min_segment_frac, kNonNegative},
      {"frontend.rect.segment_fit_px", &f.rect.segment_fit_px, kNonNegative},
      {"frontend.rect.merge_angle_deg", &f.rect.merge_angle_deg, kNonNegative},
      {"frontend.rect.merge_line_px", &f.rect.merge_line_px, kNonNegative},
      {"frontend.rect.merge_gap_frac", &f.rect.merge_gap_frac, kNonNegative},
      {"frontend.rect.curved_step_deg", &f.rect.curved_step_deg, kNonNegative},
      {"frontend.rect.curved_total_deg", &f.rect.curved_total_deg, kNonNegative},
      {"frontend.rect.curved_min_frac", &f.rect.curved_min_frac, kNonNegative},
      {"frontend.rect.curved_corner_frac", &f.rect.curved_corner_frac, kNonNegative},
      {"frontend.rect.min_side_frac", &f.rect.min_side_frac, kNonNegative},
      {"frontend.rect.min_corner_angle_deg", &f.rect.min_corner_angle_deg, kNonNegative},
      {"frontend.rect.junction_gap_frac", &f.rect.junction_gap_frac, kNonNegative},
      {"frontend.rect.junction_overshoot_frac", &f.rect.junction_overshoot_frac, kNonNegative},
      {"frontend.rect.junction_slack_px", &f.rect.junction_slack_px, kNonNegative},
      {"frontend.rect.max_hypotheses", &f.rect.max_hypotheses, kNonNegative},
      {"frontend.rect.search_px", &f.rect.search_px, kNonNegative},
      {"frontend.rect.polarity_from_segment", &f.rect.polarity_from_segment, kAny},
      {"frontend.rect.search_step_px", &f.rect.search_step_px, kNonNegative},
      {"frontend.rect.samples_per_side", &f.rect.samples_per_side, kNonNegative},
      {"frontend.rect.corner_margin_frac", &f.rect.corner_margin_frac, kNonNegative},
      {"frontend.rect.ransac_inlier_px", &f.rect.ransac_inlier_px, kNonNegative},
      {"frontend.rect.ransac_iterations", &f.rect.ransac_iterations, kNonNegative},
      {"frontend.rect.seed", &f.rect.seed, kAny},
      {"frontend.rect.bend_px", &f.rect.bend_px, kNonNegative},
      {"frontend.rect.min_side_support", &f.rect.min_side_support, kNonNegative},
      {"frontend.rect.frame_band_max_frac", &f.rect.frame_band_max_frac, kNonNegative},
      {"frontend.rect.band_max_px", &f.rect.band_max_px, kNonNegative},
      {"frontend.rect.max_side_continuation", &f.rect.max_side_continuation, kNonNegative},
      {"frontend.rect.continuation_start_px", &f.rect.continuation_start_px, kNonNegative},
      {"frontend.rect.continuation_frac", &f.rect.continuation_frac, kNonNegative},
      {"frontend.rect.continuation_step_px", &f.rect.continuation_step_px, kNonNegative},
      {"frontend.rect.min_corner_reach", &f.rect.min_corner_reach, kNonNegative},
      {"frontend.rect.reach_start_px", &f.rect.reach_start_px, kNonNegative},
      {"frontend.rect.reach_min_px", &f.rect.reach_min_px, kNonNegative},
      {"frontend.rect.reach_frac", &f.rect.reach_frac, kNonNegative},
      {"frontend.rect.max_abs_cos", &f.rect.max_abs_cos, kNonNegative},
      {"frontend.rect.max_aspect", &f.rect.max_aspect, kNonNegative},
      {"frontend.rect.assumed_hfov_deg", &f.rect.assumed_hfov_deg, kNonNegative},
      {"frontend.rect.reach_failures_allowed", &f.rect.reach_failures_allowed, kNonNegative},
      {"frontend.rect.reach_failures_any_corner", &f.rect.reach_failures_any_corner, kNonNegative},
      {"frontend.rect.any_corner_min_side_frac", &f.rect.any_corner_min_side_frac, kNonNegative},
      {"frontend.rect.reach_either_polarity", &f.rect.reach_either_polarity, kAny},
      {"frontend.rect.bridge_gap_frac", &f.rect.bridge_gap_frac, kNonNegative},
      {"frontend.rect.bridge_min_frac", &f.rect.bridge_min_frac, kNonNegative},
      {"frontend.rect.bridge_min_piece_frac", &f.rect.bridge_min_piece_frac, kNonNegative},
      {"frontend.rect.uncalibrated_reach_failures_allowed",
       &f.rect.uncalibrated_reach_failures_allowed, kNonNegative},
      {"frontend.rect.uncalibrated_container_outside_frac",
       &f.rect.uncalibrated_container_outside_frac, kNonNegative},
      {"frontend.rect.focal_prior_min", &f.rect.focal_prior_min, kNonNegative},
      {"frontend.rect.focal_prior_max", &f.rect.focal_prior_max, kNonNegative},
      {"frontend.rect.focal_prior_steps", &f.rect.focal_prior_steps, kNonNegative},
      {"frontend.rect.max_corner_outside_px", &f.rect.max_corner_outside_px, kNonNegative},
      {"frontend.rect.container_outside_frac", &f.rect.container_outside_frac, kNonNegative},
      {"frontend.rect.guess_class", &f.rect.guess_class, kAny},
      {"frontend.rect.duplicate_corner_frac", &f.rect.duplicate_corner_frac, kNonNegative},
      {"frontend.rect.nest_corner_frac", &f.rect.nest_corner_frac, kNonNegative},
      {"frontend.rect.nest_score_margin", &f.rect.nest_score_margin, kNonNegative},
      {"frontend.rect.prefer_inner_of_bright_margin", &f.rect.prefer_inner_of_bright_margin, kAny},
      {"frontend.rect.margin_min_contrast", &f.rect.margin_min_contrast, kNonNegative},
      {"frontend.rect.margin_max_texture", &f.rect.margin_max_texture, kNonNegative},
      {"frontend.rect.margin_min_width_px", &f.rect.margin_min_width_px, kNonNegative},
      {"frontend.rect.margin_probe_frac", &f.rect.margin_probe_frac, kNonNegative},
      {"frontend.rect.drop_contained", &f.rect.drop_contained, kAny},
      {"frontend.rect.max_detections", &f.rect.max_detections, kNonNegative},
      {"frontend.apriltag.family", &f.apriltag.family, kAny},
      {"frontend.apriltag.decimate", &f.apriltag.decimate, kNonNegative},
      {"frontend.apriltag.sigma", &f.apriltag.sigma, kNonNegative},
      {"frontend.apriltag.refine_edges", &f.apriltag.refine_edges, kAny},
      {"frontend.apriltag.decode_sharpening", &f.apriltag.decode_sharpening, kNonNegative},
      {"frontend.apriltag.threads", &f.apriltag.threads, kNonNegative},
      {"frontend.apriltag.max_hamming", &f.apriltag.max_hamming, kNonNegative},
      {"frontend.apriltag.min_decision_margin", &f.apriltag.min_decision_margin, kNonNegative},
      {"frontend.tracker.patch_size", &f.tracker.patch_size, kNonNegative},
      {"frontend.tracker.appearance_margin", &f.tracker.appearance_margin, kNonNegative},
      {"frontend.tracker.min_side_px", &f.tracker.min_side_px, kNonNegative},
      {"frontend.tracker.model_keypoints", &f.tracker.model_keypoints, kNonNegative},
      {"frontend.tracker.max_points", &f.tracker.max_points, kNonNegative},
      {"frontend.tracker.min_corner_gradient", &f.tracker.min_corner_gradient, kNonNegative},
      {"frontend.tracker.lk_window", &f.tracker.lk_window, kNonNegative},
      {"frontend.tracker.lk_levels", &f.tracker.lk_levels, kNonNegative},
      {"frontend.tracker.lk_iterations", &f.tracker.lk_iterations, kNonNegative},
      {"frontend.tracker.max_fb_error_px", &f.tracker.max_fb_error_px, kNonNegative},
      {"frontend.tracker.recover_fraction", &f.tracker.recover_fraction, kNonNegative},
      {"frontend.tracker.match_ratio", &f.tracker.match_ratio, kNonNegative},
      {"frontend.tracker.ransac_px", &f.tracker.ransac_px, kNonNegative},
      {"frontend.tracker.min_inliers", &f.tracker.min_inliers, kNonNegative},
      {"frontend.tracker.coarse_search_px", &f.tracker.coarse_search_px, kNonNegative},
      {"frontend.tracker.min_edge_gradient", &f.tracker.min_edge_gradient, kNonNegative},
      {"frontend.tracker.max_refine_shift_px", &f.tracker.max_refine_shift_px, kNonNegative},
      {"frontend.tracker.blur_sharpness_ratio", &f.tracker.blur_sharpness_ratio, kNonNegative},
      {"frontend.tracker.blur_align_min_appearance", &f.tracker.blur_align_min_appearance,
       kNonNegative},
      {"frontend.tracker.blur_align_max_shift_px", &f.tracker.blur_align_max_shift_px,
       kNonNegative},
      {"frontend.tracker.blur_shape_from_prediction", &f.tracker.blur_shape_from_prediction, kAny},
      {"frontend.tracker.fast_align_min_motion_px", &f.tracker.fast_align_min_motion_px,
       kNonNegative},
      {"frontend.tracker.fast_align_max_shift_px", &f.tracker.fast_align_max_shift_px,
       kNonNegative},
      {"frontend.tracker.fast_align_min_ncc", &f.tracker.fast_align_min_ncc, kNonNegative},
      {"frontend.tracker.min_appearance", &f.tracker.min_appearance, kNonNegative},
      {"frontend.tracker.min_visible", &f.tracker.min_visible, kNonNegative},
      {"frontend.tracker.refresh_every", &f.tracker.refresh_every, kNonNegative},
      {"frontend.tracker.refresh_appearance", &f.tracker.refresh_appearance, kNonNegative},
  };
}

// Names of the enum values as written in the file.
const std::vector<std::pair<EstimatorMode, const char*>> kModes = {
    {EstimatorMode::kWindow, "window"}, {EstimatorMode::kBatch, "batch"}};
const std::vector<std::pair<LandmarkType, const char*>> kLandmarks = {{LandmarkType::kFsp, "fsp"},
                                                                      {LandmarkType::kFhp, "fhp"}};
const std::vector<std::pair<WindowBoundary, const char*>> kBoundaries = {
    {WindowBoundary::kPrior, "prior"}, {WindowBoundary::kFixed, "fixed"}};
const std::vector<std::pair<RobustLossOptions::Type, const char*>> kLosses = {
    {RobustLossOptions::Type::kNone, "none"},
    {RobustLossOptions::Type::kHuber, "huber"},
    {RobustLossOptions::Type::kCauchy, "cauchy"}};

template <typename E>
const std::vector<std::pair<E, const char*>>& EnumNames() {
  if constexpr (std::is_same_v<E, EstimatorMode>) {
    return kModes;
  } else if constexpr (std::is_same_v<E, LandmarkType>) {
    return kLandmarks;
  } else if constexpr (std::is_same_v<E, WindowBoundary>) {
    return kBoundaries;
  } else {
    return kLosses;
  }
}

std::string FormatDouble(double v) {
  char buf[64];
  const auto res = std::to_chars(buf, buf + sizeof(buf), v);  // shortest round-trip form
  std::string s(buf, res.ptr);
  // Keep it a float in YAML's eyes ("1" -> "1.0") unless it is in exponent form.
  if (s.find_first_of(".eEn") == std::string::npos) s += ".0";
  return s;
}

std::string FormatValue(const FieldRef& ref) {
  return std::visit(
      [](auto* p) -> std::string {
        using T = std::remove_pointer_t<decltype(p)>;
        if constexpr (std::is_same_v<T, int> || std::is_same_v<T, uint32_t>) {
          return std::to_string(*p);
        } else if constexpr (std::is_same_v<T, double>) {
          return FormatDouble(*p);
        } else if constexpr (std::is_same_v<T, bool>) {
          return *p ? "true" : "false";
        } else if constexpr (std::is_same_v<T, std::string>) {
          return *p;
        } else if constexpr (std::is_same_v<T, std::optional<double>>) {
          return p->has_value() ? FormatDouble(**p) : "null";
        } else {
          for (const auto& [value, name] : EnumNames<T>())
            if (value == *p) return name;
          return "?";
        }
      },
      ref);
}

class ConfigParser {
 public:
  ConfigParser(RunConfig* config, std::string name) : config_(config), name_(std::move(name)) {
    for (Field& f : Fields(*config_)) {
      fields_.emplace(f.key, f);
      // Every proper prefix of a key is a section.
      for (size_t dot = f.key.find('.'); dot != std::string::npos; dot = f.key.find('.', dot + 1))
        sections_.insert(f.key.substr(0, dot));
    }
  }

  void ParseRoot(const YAML::Node& root) {
    if (!root || root.IsNull()) return;  // an empty file: all defaults
    if (!root.IsMap())
      Fail(root, "", "the config must be a map of sections (estimator, imu, frontend)");
    ParseSection(root, "");
  }

 private:
  [[noreturn]] void Fail(const YAML::Node& node, const std::string& key,
                         const std::string& what) const {
    const int line = node.Mark().is_null() ? 0 : node.Mark().line + 1;
    throw InputError(name_, line, key.empty() ? what : key + ": " + what);
  }

  void ParseSection(const YAML::Node& map, const std::string& prefix) {
    for (const auto& kv : map) {
      const std::string name = kv.first.as<std::string>();
      const std::string key = prefix.empty() ? name : prefix + "." + name;
      const YAML::Node& value = kv.second;
      if (sections_.count(key)) {
        if (value.IsNull()) continue;  // "imu:" with nothing under it
        if (!value.IsMap()) Fail(kv.first, key, "is a section: expected keys under it");
        ParseSection(value, key);
        continue;
      }
      auto it = fields_.find(key);
      if (it == fields_.end()) Fail(kv.first, key, "unknown key" + Suggest(prefix));
      if (!seen_.insert(key).second) Fail(kv.first, key, "given twice");
      ParseValue(it->second, value);
    }
  }

  // "(known keys here: a, b, c)" for an unknown key's message.
  std::string Suggest(const std::string& prefix) const {
    std::string known;
    const std::string p = prefix.empty() ? "" : prefix + ".";
    std::set<std::string> names;
    for (const auto& [key, f] : fields_) {
      if (key.compare(0, p.size(), p) != 0) continue;
      const std::string rest = key.substr(p.size());
      names.insert(rest.substr(0, rest.find('.')));
    }
    for (const std::string& n : names) known += (known.empty() ? "" : ", ") + n;
    return known.empty() ? std::string()
                         : " (known keys" + (prefix.empty() ? std::string() : " in " + prefix) +
                               ": " + known + ")";
  }

  double ParseNumber(const Field& f, const YAML::Node& node, bool integer) const {
    if (!node.IsScalar()) Fail(node, f.key, "expected a number");
    const std::string text = node.Scalar();
    char* end = nullptr;
    double v = 0.0;
    if (integer) {
      errno = 0;
      const long long i = std::strtoll(text.c_str(), &end, 10);
      if (end == text.c_str() || *end != '\0' || errno == ERANGE)
        Fail(node, f.key, "expected an integer, got '" + text + "'");
      v = static_cast<double>(i);
    } else {
      v = std::strtod(text.c_str(), &end);
      if (end == text.c_str() || *end != '\0' || !std::isfinite(v))
        Fail(node, f.key, "expected a finite number, got '" + text + "'");
    }
    const Range& r = f.range;
    const bool low_ok = r.lo_open ? v > r.lo : v >= r.lo;
    if (!low_ok || v > r.hi) {
      std::ostringstream os;
      os << "must be ";
      if (r.hi == kInf) {
        os << (r.lo_open ? "> " : ">= ") << r.lo;
      } else {
        os << "in " << (r.lo_open ? "(" : "[") << r.lo << ", " << r.hi << "]";
      }
      os << ", got " << text;
      Fail(node, f.key, os.str());
    }
    return v;
  }

  void ParseValue(const Field& f, const YAML::Node& node) {
    std::visit(
        [&](auto* p) {
          using T = std::remove_pointer_t<decltype(p)>;
          if constexpr (std::is_same_v<T, int>) {
            const double v = ParseNumber(f, node, true);
            if (std::abs(v) > std::numeric_limits<int>::max()) Fail(node, f.key, "too large");
            *p = static_cast<int>(v);
          } else if constexpr (std::is_same_v<T, uint32_t>) {
            const double v = ParseNumber(f, node, true);
            if (v < 0 || v > std::numeric_limits<uint32_t>::max())
              Fail(node, f.key, "must be in [0, 4294967295], got " + node.Scalar());
            *p = static_cast<uint32_t>(v);
          } else if constexpr (std::is_same_v<T, double>) {
            *p = ParseNumber(f, node, false);
          } else if constexpr (std::is_same_v<T, std::optional<double>>) {
            if (node.IsNull()) {
              p->reset();
            } else {
              *p = ParseNumber(f, node, false);
            }
          } else if constexpr (std::is_same_v<T, std::string>) {
            if (!node.IsScalar() || node.Scalar().empty()) Fail(node, f.key, "expected a name");
            *p = node.Scalar();
          } else if constexpr (std::is_same_v<T, bool>) {
            const std::string s = node.IsScalar() ? node.Scalar() : "";
            if (s == "true") {
              *p = true;
            } else if (s == "false") {
              *p = false;
            } else {
              Fail(node, f.key, "expected true or false, got '" + s + "'");
            }
          } else {
            const std::string s = node.IsScalar() ? node.Scalar() : "";
            std::string names;
            for (const auto& [value, name] : EnumNames<T>()) {
              if (s == name) {
                *p = value;
                return;
              }
              names += (names.empty() ? "" : ", ") + std::string(name);
            }
            Fail(node, f.key, "expected one of " + names + ", got '" + s + "'");
          }
        },
        f.ref);
  }

  RunConfig* config_;
  std::string name_;
  std::map<std::string, Field> fields_;
  std::set<std::string> sections_;
  std::set<std::string> seen_;
};

}  // namespace

bool GtCornersOptions::Check(std::string* why) const {
  if (!(pixel_sigma >= 0.0) || !std::isfinite(pixel_sigma)) {
    if (why) *why = "frontend.gt_corners.pixel_sigma must be finite and >= 0";
    return false;
  }
  if (min_visible_corners < 2 || min_visible_corners > 4) {
    if (why) *why = "frontend.gt_corners.min_visible_corners must be 2, 3 or 4";
    return false;
  }
  return true;
}

ImuNoise ImuNoiseOverrides::Apply(ImuNoise noise) const {
  if (gyroscope_noise_density) noise.gyroscope_noise_density = *gyroscope_noise_density;
  if (accelerometer_noise_density) noise.accelerometer_noise_density = *accelerometer_noise_density;
  if (gyroscope_random_walk) noise.gyroscope_random_walk = *gyroscope_random_walk;
  if (accelerometer_random_walk) noise.accelerometer_random_walk = *accelerometer_random_walk;
  return noise;
}

RunConfig ParseRunConfig(const std::string& yaml_text, const std::string& name) {
  RunConfig config;
  config.source = name;
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    throw InputError(name, e.mark.is_null() ? 0 : e.mark.line + 1, "not valid YAML: " + e.msg);
  }
  ConfigParser parser(&config, name);
  try {
    parser.ParseRoot(root);
  } catch (const YAML::Exception& e) {
    throw InputError(name, e.mark.is_null() ? 0 : e.mark.line + 1, e.msg);
  }
  std::string why;
  if (!config.gt_corners.Check(&why) || !config.estimator.Check(&why))
    throw InputError(name, 0, why);
  if (!config.frontend.Check(&why)) throw InputError(name, 0, "frontend: " + why);
  return config;
}

RunConfig ReadRunConfig(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path, 0, "cannot open the config file");
  std::stringstream ss;
  ss << in.rdbuf();
  return ParseRunConfig(ss.str(), path);
}

std::vector<std::string> RunConfigKeys() {
  RunConfig c;
  std::vector<std::string> keys;
  for (const Field& f : Fields(c)) keys.push_back(f.key);
  return keys;
}

bool SameValues(const RunConfig& a, const RunConfig& b, std::string* first_difference) {
  RunConfig ca = a, cb = b;
  const std::vector<Field> fa = Fields(ca), fb = Fields(cb);
  for (size_t i = 0; i < fa.size(); ++i) {
    const std::string va = FormatValue(fa[i].ref), vb = FormatValue(fb[i].ref);
    if (va != vb) {
      if (first_difference) *first_difference = fa[i].key + ": " + va + " vs " + vb;
      return false;
    }
  }
  return true;
}

std::string ToYaml(const RunConfig& config) {
  RunConfig c = config;
  std::ostringstream os;
  std::vector<std::string> open;  // sections currently open
  for (const Field& f : Fields(c)) {
    std::vector<std::string> parts;
    std::stringstream ks(f.key);
    for (std::string part; std::getline(ks, part, '.');) parts.push_back(part);
    size_t common = 0;
    while (common < open.size() && common + 1 < parts.size() && open[common] == parts[common])
      ++common;
    open.resize(common);
    for (size_t i = common; i + 1 < parts.size(); ++i) {
      os << std::string(2 * i, ' ') << parts[i] << ":\n";
      open.push_back(parts[i]);
    }
    os << std::string(2 * (parts.size() - 1), ' ') << parts.back() << ": " << FormatValue(f.ref)
       << "\n";
  }
  return os.str();
}

}  // namespace fsp::apps
