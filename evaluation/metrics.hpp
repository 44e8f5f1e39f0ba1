#pragma once
// Pure metric functions: no files, no printing. Executables call them and write reports.

#include "core/types.hpp"

#include <array>
#include <cstddef>
#include <vector>

namespace terrain::eval {

// The ground segmentations a report scores, by their key in report.json's ground_segmentation and
// in 'terrain kitti''s output: the method's rough classes, its GMRF by ICM and by min-cut, then the
// baselines (a fixed band, a RANSAC plane, PCL's progressive morphological filter).
inline constexpr std::array<const char*, 6> kGroundMethods = {"histogram",  "gmrf_icm",     "gmrf_mincut",
                                                              "fixed_band", "ransac_plane", "morphological_filter"};

// Scores of a binary classification (the positive class is ground).
struct BinaryScores {
  std::size_t tp = 0, fp = 0, fn = 0, tn = 0;
  double precision = 0, recall = 0, f1 = 0, iou = 0;  // 0 where undefined (no positives)
};

// From counts.
BinaryScores binaryScores(std::size_t tp, std::size_t fp, std::size_t fn, std::size_t tn);
// From paired labels (true = positive); entries with skip[i] set are left out (skip may be empty).
BinaryScores binaryScores(const std::vector<bool>& predicted, const std::vector<bool>& truth,
                          const std::vector<bool>& skip = {});

// Errors e_i = estimate_i - truth_i.
struct ErrorStats {
  std::size_t count = 0;
  double mae = 0;       // mean |e| [m]
  double rmse = 0;      // sqrt(mean e^2) [m]
  double bias = 0;      // mean e [m]
  double variance = 0;  // mean (e - bias)^2 [m^2]
};
ErrorStats errorStats(const std::vector<double>& errors);

// Median and 95th percentile (nearest rank) of a sample; 0 for an empty sample.
struct Percentiles {
  double median = 0, p95 = 0;
};
Percentiles percentiles(std::vector<double> values);

// How far an estimated vehicle pose (world_from_vehicle; x forward, y left, z up) lies from the
// true one, each as an absolute value: the position's horizontal and vertical offsets [m]; the
// heading (the forward axis' azimuth), pitch (its elevation) and roll (the left axis' elevation)
// differences [rad].
struct PoseError {
  double horizontal = 0, vertical = 0;
  double heading = 0, pitch = 0, roll = 0;
};
PoseError poseError(const Pose& estimated, const Pose& truth);

}  // namespace terrain::eval
