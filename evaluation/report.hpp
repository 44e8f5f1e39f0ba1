#pragma once
// The evaluation of a run: every metric of the paper's method beside the baselines, as JSON with
// stable field names (report.json), from the pipeline's final state and the truth gathered on the
// side while it ran.

#include "core/pipeline.hpp"
#include "evaluation/ground_truth.hpp"
#include "evaluation/scoring.hpp"

#include <nlohmann/json.hpp>

#include <array>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace terrain::eval {

// A camera image kept for boundary coverage: its truth segmentation and true camera pose.
struct CameraTruthFrame {
  int frame = 0;
  int camera = 0;        // index into RigCalibration::cameras
  cv::Mat rgb;           // for the overlay in the HTML report
  cv::Mat segmentation;  // CV_16UC1 geom id + 1
  Pose world_from_camera = Pose::Identity();
};

// Truth gathered beside a run.
struct RunTruth {
  explicit RunTruth(double voxel_size) : voxels(voxel_size) {}
  VoxelTruth voxels;
  std::vector<Point3> path;  // true vehicle positions
  std::vector<CameraTruthFrame> cameras;
  int camera_stride = 0;  // frames between kept camera frames (0: camera_every)
};

// Adds one frame's truth. Every `camera_every`-th frame keeps every camera's truth (RGB and true
// segmentation, ~1.5 MB a camera at 640x480); past kMaxCameraFrames kept frames every second one is
// dropped and the stride doubles, so a long run's memory does not grow with its length.
constexpr std::size_t kMaxCameraFrames = 64;
void addFrameTruth(RunTruth& truth, const rig::RigFrame& frame, const RigCalibration& calibration, int camera_every);

// How many frames the kept camera images come from (a frame's cameras count once).
std::size_t keptFrameCount(const RunTruth& truth);

struct BoundaryCoverage {
  double before = 0, after = 0;  // share of true top-boundary pixels reproduced
  std::size_t boundary_pixels = 0;
  std::size_t occluded_pixels = 0;  // object edges under a nearer surface, left out
};

// Boundary coverage of one camera frame: the true top-boundary pixels are object pixels (building,
// trunk, crown) whose upper neighbour is the sky or belongs to another geom (object or ground) that
// lies farther along its ray than the pixel's own surface: the object's outline against what is
// behind it. Where the upper neighbour is nearer (a crown hiding the top of the trunk under it or
// of a facade behind), the edge is the nearer surface's lower one and the object's top lies
// elsewhere; no height field reproduces it, so such pixels are counted apart (occluded_pixels).
// One is reproduced when a vertex of the mesh over an object cell, projected at its height into
// the image, lands within `tolerance` pixels of it. Computed for the sensed heights (before) and
// the recovered heights with the roof cells of completed footprints (after).
BoundaryCoverage boundaryCoverage(const TerrainMesh& mesh, const std::vector<RoofCell>& roof, double voxel_size,
                                  const sim::World& world, const CameraIntrinsics& intrinsics,
                                  const CameraTruthFrame& frame, int tolerance);

// Boundary coverage over every kept camera image: each image's, and the means weighted by boundary
// pixels over all of them and per camera (by index into the calibration's cameras).
struct CoverageSum {
  double before = 0, after = 0;  // coverage times boundary pixels, summed
  std::size_t pixels = 0, occluded = 0, images = 0;
  double meanBefore() const { return pixels ? before / pixels : 0.0; }
  double meanAfter() const { return pixels ? after / pixels : 0.0; }
};
struct ImageCoverage {
  int frame = 0, camera = 0;
  BoundaryCoverage coverage;
};
struct CoverageScores {
  std::vector<ImageCoverage> images;
  CoverageSum all;
  std::map<int, CoverageSum> by_camera;
};
CoverageScores scoreBoundaryCoverage(const TerrainMesh& mesh, const std::vector<RoofCell>& roof, double voxel_size,
                                     const sim::World& world, const RigCalibration& calibration,
                                     const std::vector<CameraTruthFrame>& frames, int tolerance);

// The intrinsics of the camera that took a kept image (frame.camera into calibration.cameras).
const CameraIntrinsics& intrinsicsOf(const RigCalibration& calibration, const CameraTruthFrame& frame);

// How high above its base [m] an object's lower part reaches: the part a vehicle's lidar, capped a
// little above its roof (1.5 m above a sensor 1.8 m up by default), senses and the method raises.
constexpr double kLowerPart = 3.0;

// The kept camera frames that saw an object's top, and of them those that also saw its lower part.
// The method can only raise an object from a frame that sees both: its sensed vertices are in the
// lower part, and their top boundary above them.
struct TopSightings {
  int top = 0;
  int with_lower_part = 0;
};

// The kept camera frames that saw each object's top, by object id (a frame counts once however many
// of its cameras saw it): frames in which a top-boundary
// pixel of the object (as in boundaryCoverage) looks at a point of it no more than 15 % of its
// height, and at least 1 m, below its highest point; with_lower_part counts those in which also a
// bottom-boundary pixel of the object (its lower neighbour another object, the ground or the sky)
// looks at a point of it within kLowerPart of its base. Objects whose top no frame saw are absent.
std::map<std::string, TopSightings> topSeenFrames(const sim::World& world, const RigCalibration& calibration,
                                                  const std::vector<CameraTruthFrame>& frames);

// Do the tops a camera saw stand at their real height (within topTolerance)? Per object seen
// (topSeenFrames) its error sensed only (before: the sensed top, or its base where nothing of it was
// sensed) and after recovery, and for a tree what crown completion made of the trunks within 1.5 m
// of its centre (a trunk whose object changed as it grew has several records: their outcomes
// summed, the verdict that got furthest). Per class ("building", "tree"): objects seen, at their
// real height and above it by more than the tolerance, before and after; and the same over those
// seen with their lower part.
struct TopCount {
  std::size_t seen = 0, before = 0, after = 0, high_before = 0, high_after = 0;
  void add(double error_before, double error_after, double tolerance);
};
struct TreeCrown {
  std::size_t records = 0;
  std::array<std::uint64_t, kCrownOutcomes> outcomes{};
  CrownVerdict verdict = CrownVerdict::NotApplied;
};
struct TopScore {
  ObjectTop top;
  TopSightings sightings;
  double error_before = 0, error_after = 0, tolerance = 0;  // [m]
  std::optional<TreeCrown> crown;                           // trees with a trunk record only
};
struct ClassTops {
  TopCount all, with_lower_part;
  ErrorStats before, after;
};
struct TopScores {
  std::map<std::string, TopScore> objects;  // by object id
  std::map<std::string, ClassTops> by_class;
};
TopScores scoreObjectTops(const HeightScores& heights, const std::map<std::string, TopSightings>& seen,
                          const std::vector<CrownRecord>& crowns, const sim::World& world);

struct EvaluationOptions {
  // score the ground segmentation baselines (fixed band, RANSAC plane, PCL's progressive
  // morphological filter); the filter takes about a minute on a map of a few million voxels
  bool ground_baselines = true;
};

// The full report. Re-runs the segmentation with both solvers on the final map, runs the baselines
// (the ground ones unless options say not to: then ground_segmentation.baselines_skipped says so).
nlohmann::json evaluateRun(const Pipeline& pipeline, const RunTruth& truth, const sim::World& world,
                           const EvaluationOptions& options = {});

// Flattens a report into "a.b.c" -> number for the numeric leaves.
std::map<std::string, double> flattenMetrics(const nlohmann::json& report);

// The pipeline's final vehicle poses at the kept camera frames against the true ones: "frames"
// compared, and the median and max of the absolute horizontal and vertical position errors [m]
// and heading, pitch and roll errors [deg] (eval::poseError).
nlohmann::json poseJson(const Pipeline& pipeline, const RunTruth& truth);

// [ms] the rig's sensing period: the median time between the starts of consecutive sweeps (100 ms
// at the HDL-64E's 10 Hz); 0 with fewer than two frames.
double sensingPeriodMs(const std::vector<FrameRecord>& records);

// Timing summary of a pipeline's records: stage -> (median, p95) [ms], the sensing period
// (sensing_period_ms) and the frames whose processing took longer (frames_over_sensing_period).
nlohmann::json timingJson(const std::vector<FrameRecord>& records);

}  // namespace terrain::eval
