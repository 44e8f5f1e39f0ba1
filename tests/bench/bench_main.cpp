// Benchmarks for the performance targets (docs/performance.md). Run through scripts/bench, which
// builds Release; the table at the end gives each figure's median, its target and, where there is
// one, the ratio against a baseline measured in the same run.
#include "app/bounded_queue.hpp"
#include "core/ground_segmentation.hpp"
#include "core/pipeline.hpp"
#include "core/random.hpp"
#include "evaluation/baselines.hpp"
#include "evaluation/kitti.hpp"
#include "rig/kitti.hpp"
#include "scenes/scene_generator.hpp"
#include "sim/camera.hpp"
#include "sim/lidar.hpp"
#include "sim/ray_caster.hpp"
#include "sim/simulated_rig.hpp"
#include "sim/world.hpp"

#include <benchmark/benchmark.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <thread>
#include <unordered_map>

namespace {

using namespace terrain;
namespace fs = std::filesystem;

// the urban scene of the performance target: about 300 geoms on heightfield terrain
const sim::World& urbanWorld() {
  static std::unique_ptr<sim::World> world = [] {
    const fs::path dir = fs::temp_directory_path() / "terrain_bench";
    fs::create_directories(dir);
    scenes::writeScene(scenes::generateScene(scenes::SceneConfig{"urban", 1}), dir / "urban_1.xml", true);
    return std::make_unique<sim::World>(dir / "urban_1.xml");
  }();
  return *world;
}

// one HDL-64E revolution of rays from the robot's start: 64 lasers x 2083 firings
struct Rays {
  std::vector<Vector3> origin, dir;
};
const Rays& sweepRays() {
  static Rays rays = [] {
    const auto& w = urbanWorld();
    const rig::LaserCalibration lasers =
        rig::loadLaserCalibration(std::string(TERRAIN_SOURCE_DIR) + "/data/calibration/hdl64e_s2.1-sztaki.yaml");
    const Eigen::Vector2d start = w.truth().path.front();
    const Vector3 sensor(start.x(), start.y(), w.terrainHeight(start.x(), start.y()) + 1.8);
    Rays r;
    for (int j = 0; j < 2083; ++j) {
      for (const auto& l : lasers.lasers) {
        Vector3 o, d;
        rig::laserRay(l, rig::velodyne::stepToRadians(rig::velodyne::encoderStep(j, 2083)), o, d);
        r.origin.push_back(sensor + o);
        r.dir.push_back(d);
      }
    }
    return r;
  }();
  return rays;
}

void BM_LidarRays_MjRay(benchmark::State& state) {
  const auto& w = urbanWorld();
  const sim::RayCaster caster(w.model(), w.data(), w.robotBody());
  const Rays& rays = sweepRays();
  std::size_t i = 0;
  for (auto _ : state) {
    // a slice of the sweep per iteration: brute force is slow
    for (int k = 0; k < 2000; ++k, i = (i + 97) % rays.dir.size())
      benchmark::DoNotOptimize(caster.castReference(rays.origin[i], rays.dir[i]));
  }
  state.SetItemsProcessed(state.iterations() * 2000);
}
BENCHMARK(BM_LidarRays_MjRay)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_LidarRays_Accelerated(benchmark::State& state) {
  const auto& w = urbanWorld();
  const sim::RayCaster caster(w.model(), w.data(), w.robotBody());
  const Rays& rays = sweepRays();
  const int threads = static_cast<int>(state.range(0));
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
  for (auto _ : state) {
    std::vector<int> hits(rays.dir.size());
    tbb::parallel_for(std::size_t{0}, rays.dir.size(),
                      [&](std::size_t k) { hits[k] = caster.cast(rays.origin[k], rays.dir[k]).geom; });
    benchmark::DoNotOptimize(hits.data());
  }
  state.SetItemsProcessed(state.iterations() * static_cast<long>(rays.dir.size()));
}
BENCHMARK(BM_LidarRays_Accelerated)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

// the points of the sweep of sweepRays() as the lidar returns them (hits within the HDL-64E's 120 m)
const std::vector<Point3>& sweepPoints() {
  static const std::vector<Point3> points = [] {
    const auto& w = urbanWorld();
    const sim::RayCaster caster(w.model(), w.data(), w.robotBody());
    const Rays& rays = sweepRays();
    std::vector<Point3> out;
    for (std::size_t k = 0; k < rays.dir.size(); ++k) {
      const sim::RayHit hit = caster.cast(rays.origin[k], rays.dir[k]);
      if (hit.geom >= 0 && hit.distance <= 120.0) out.push_back(rays.origin[k] + hit.distance * rays.dir[k]);
    }
    return out;
  }();
  return points;
}

// one frame's voxel insertion on a moving robot: the sweep, moved on by 0.5 m per frame, into a
// map that holds the ten sweeps before it. Arg 1: VoxelMap::insert; arg 0: the straightforward
// way, a std::unordered_map from packed voxel index to voxel (the baseline).
void BM_VoxelInsert(benchmark::State& state) {
  const std::vector<Point3>& sweep = sweepPoints();
  const auto moved = [&](double dx) {
    std::vector<Point3> p(sweep);
    for (auto& q : p) q.x() += dx;
    return p;
  };
  VoxelMap map(VoxelMapConfig{0.2});
  std::unordered_map<std::uint64_t, Voxel> hashed;
  const auto insertHashed = [&](const std::vector<Point3>& points, std::uint32_t frame) {
    for (const Point3& p : points) {
      const VoxelIndex i = map.indexOf(p);
      Voxel& v = hashed[VoxelMap::pack(i)];
      v.index = i;
      v.hits += 1;
      v.height += static_cast<float>((p.z() - v.height) / v.hits);
      v.frame = frame;
    }
  };
  const bool optimised = state.range(0) == 1;
  std::uint32_t frame = 0;
  for (; frame < 10; ++frame) {
    const std::vector<Point3> p = moved(0.5 * frame);
    if (optimised)
      map.insert(p, frame);
    else
      insertHashed(p, frame);
  }
  for (auto _ : state) {
    state.PauseTiming();
    const std::vector<Point3> p = moved(0.5 * frame);
    state.ResumeTiming();
    if (optimised)
      map.insert(p, frame);
    else
      insertHashed(p, frame);
    ++frame;
  }
  state.SetItemsProcessed(state.iterations() * static_cast<long>(sweep.size()));
  state.counters["voxels"] = static_cast<double>(optimised ? map.size() : hashed.size());
  state.counters["points"] = static_cast<double>(sweep.size());
}
BENCHMARK(BM_VoxelInsert)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(20);

// a voxel map of about 1.8 M voxels: 1.2 M ground voxels of rolling terrain, walls, noise
VoxelMap& bigMap() {
  static std::unique_ptr<VoxelMap> map = [] {
    auto m = std::make_unique<VoxelMap>(VoxelMapConfig{0.2});
    std::vector<Point3> pts;
    Random rng(1);
    for (int x = 0; x < 1300; ++x) {
      for (int y = 0; y < 1300; ++y) {
        const double px = x * 0.2 + 0.1, py = y * 0.2 + 0.1;
        pts.emplace_back(px, py, 0.5 * std::sin(px / 15) + 0.3 * std::cos(py / 9) + 0.01 * rng.normal());
        // walls every 20 m, 15 voxels high
        if (x % 100 == 0 || y % 100 == 0) {
          for (int z = 1; z < 5; ++z)
            pts.emplace_back(px, py, 0.5 * std::sin(px / 15) + 0.3 * std::cos(py / 9) + z * 0.2);
        }
      }
    }
    m->insert(pts, 0);
    return m;
  }();
  return *map;
}

// the whole map segmented in fresh memory, as the pipeline segments its final map and the
// evaluation segments a map with the other solver (segmentGroundLabels): ICM (0) or min-cut (1)
void BM_Segmentation(benchmark::State& state) {
  VoxelMap& map = bigMap();
  GroundSegmentationConfig cfg;
  cfg.solver = state.range(0) == 0 ? GroundSegmentationConfig::Solver::Icm : GroundSegmentationConfig::Solver::MinCut;
  for (auto _ : state) benchmark::DoNotOptimize(segmentGroundLabels(map, cfg).refined.data());
  state.counters["voxels"] = static_cast<double>(map.size());
  state.counters["bytes_per_voxel"] = static_cast<double>(map.memoryBytes()) / map.size();
}
BENCHMARK(BM_Segmentation)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(3);

// the per-frame update: a map of the benchmark's 1.8 M voxels that receives 125 k new voxels
// (a 19 m strip of new terrain along its edge, 1300 x 96 columns) per iteration, segmented
// incrementally
void BM_SegmentationIncremental(benchmark::State& state) {
  VoxelMap map(VoxelMapConfig{0.2});
  IncrementalGroundSegmentation inc(GroundSegmentationConfig{});
  auto terrain = [](int x, int y, std::vector<Point3>& pts, Random& rng) {
    const double px = x * 0.2 + 0.1, py = y * 0.2 + 0.1;
    pts.emplace_back(px, py, 0.5 * std::sin(px / 15) + 0.3 * std::cos(py / 9) + 0.01 * rng.normal());
    if (x % 100 == 0 || y % 100 == 0) {
      for (int z = 1; z < 5; ++z) pts.emplace_back(px, py, 0.5 * std::sin(px / 15) + 0.3 * std::cos(py / 9) + z * 0.2);
    }
  };
  Random rng(1);
  {
    std::vector<Point3> pts;
    for (int x = 0; x < 1300; ++x) {
      for (int y = 0; y < 1300; ++y) terrain(x, y, pts, rng);
    }
    map.insert(pts, 0);
    inc.update(map);
  }
  int x0 = 1300;
  std::size_t added = 0;
  for (auto _ : state) {
    state.PauseTiming();
    std::vector<Point3> pts;
    for (int x = x0; x < x0 + 96; ++x) {
      for (int y = 0; y < 1300; ++y) terrain(x, y, pts, rng);
    }
    x0 += 96;
    const std::size_t before = map.size();
    map.insert(pts, 1);
    added = map.size() - before;
    state.ResumeTiming();
    inc.update(map);
  }
  state.counters["new_voxels"] = static_cast<double>(added);
  state.counters["voxels"] = static_cast<double>(map.size());
}
BENCHMARK(BM_SegmentationIncremental)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(5);

// the straightforward way: a std::unordered_map from voxel key to height and label, the global
// histogram, ICM with hash look-ups for every neighbour in every sweep
void BM_Segmentation_NaiveHashMap(benchmark::State& state) {
  const VoxelMap& map = bigMap();
  for (auto _ : state) {
    std::unordered_map<std::uint64_t, std::pair<float, std::uint8_t>> voxels;
    auto key = [](const VoxelIndex& i) {
      return (static_cast<std::uint64_t>(i.x() + (1 << 20)) << 42) |
             (static_cast<std::uint64_t>(i.y() + (1 << 20)) << 21) | static_cast<std::uint64_t>(i.z() + (1 << 20));
    };
    std::vector<double> heights;
    for (const auto& v : map.voxels()) voxels[key(v.index)] = {v.height, 0}, heights.push_back(v.height);
    const double h1 = histogramPeak(heights, 0.1);
    for (auto& [k, v] : voxels) v.second = std::abs(v.first - h1) <= 0.3;
    std::unordered_map<std::uint64_t, std::uint8_t> rough;
    for (auto& [k, v] : voxels) rough[k] = v.second;
    for (int sweep = 0; sweep < 5; ++sweep) {
      for (const auto& vx : map.voxels()) {
        auto& self = voxels[key(vx.index)];
        double cg = rough[key(vx.index)] ? -2 : 2, cn = -cg;
        for (int axis = 0; axis < 3; ++axis) {
          for (int s = -1; s <= 1; s += 2) {
            VoxelIndex j = vx.index;
            j[axis] += s;
            auto it = voxels.find(key(j));
            if (it == voxels.end()) continue;
            const double w = 0.6 + 0.6 * std::exp(-std::abs(self.first - it->second.first));
            cg += it->second.second ? -w : w;
            cn += it->second.second ? w : -w;
          }
        }
        self.second = cg < cn;
      }
    }
    benchmark::DoNotOptimize(voxels.size());
  }
}
BENCHMARK(BM_Segmentation_NaiveHashMap)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1);

void BM_CameraRender(benchmark::State& state) {
  const auto& w = urbanWorld();
  sim::CameraRenderer cam(w, sim::CameraMount{});
  const Eigen::Vector2d start = w.truth().path.front();
  Pose pose = Pose::Identity();
  pose.linear().col(0) = Vector3(0, -1, 0);
  pose.linear().col(1) = Vector3(0, 0, -1);
  pose.linear().col(2) = Vector3(1, 0, 0);
  pose.translation() = Vector3(start.x(), start.y(), w.terrainHeight(start.x(), start.y()) + 1.6);
  for (auto _ : state) benchmark::DoNotOptimize(cam.render(pose).rgb.data);
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_CameraRender)->Unit(benchmark::kMillisecond)->UseRealTime();

// the default (surround) camera rig, every camera at 640x480 rendered at the start of the urban
// path: one rig frame per iteration
void BM_CameraRig(benchmark::State& state) {
  const auto& w = urbanWorld();
  const sim::SimConfig config;
  const RigCalibration calibration = sim::SimulatedRig::calibrationFor(config, GeodeticOrigin{});
  std::vector<std::unique_ptr<sim::CameraRenderer>> cameras;
  for (const auto& m : sim::rigCameras(config.camera)) cameras.push_back(std::make_unique<sim::CameraRenderer>(w, m));
  const Eigen::Vector2d start = w.truth().path.front();
  Pose vehicle = Pose::Identity();
  vehicle.translation() = Vector3(start.x(), start.y(), w.terrainHeight(start.x(), start.y()));
  for (auto _ : state) {
    for (std::size_t c = 0; c < cameras.size(); ++c)
      benchmark::DoNotOptimize(cameras[c]->render(vehicle * calibration.cameras[c].vehicle_from_camera).rgb.data);
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["cameras"] = static_cast<double>(cameras.size());
}
BENCHMARK(BM_CameraRig)->Unit(benchmark::kMillisecond)->UseRealTime();

// the two real scans of tests/data, for the segmentation benchmarks
const std::vector<std::vector<Point3>>& kittiScans() {
  static const std::vector<std::vector<Point3>> scans = [] {
    std::vector<std::vector<Point3>> out;
    for (const char* name : {"000000", "000020"})
      out.push_back(
          rig::readKittiScan(std::string(TERRAIN_SOURCE_DIR) + "/tests/data/semantickitti/" + name + ".bin").points);
    return out;
  }();
  return scans;
}

GroundSegmentationConfig kittiSolver(std::int64_t arg) {
  GroundSegmentationConfig cfg;
  cfg.solver = arg == 0 ? GroundSegmentationConfig::Solver::Icm : GroundSegmentationConfig::Solver::MinCut;
  return cfg;
}

// real scans segmented one after another as 'terrain kitti' and a robot's sweeps are, by one
// ScanSegmenter (its memory kept from scan to scan), by ICM (0) or min-cut (1): scans 000000 and
// 000020 in turn, one per iteration
void BM_KittiScanSegmentation(benchmark::State& state) {
  const auto& scans = kittiScans();
  ScanSegmenter segmenter(VoxelMapConfig{}, kittiSolver(state.range(0)));
  segmenter.segment(scans[1]);
  std::size_t i = 0;
  for (auto _ : state) benchmark::DoNotOptimize(segmenter.segment(scans[i++ % scans.size()]).data());
}
BENCHMARK(BM_KittiScanSegmentation)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime();

// the same with a segmenter made for each scan (its memory taken afresh, as a single call costs)
void BM_KittiScanSegmentationFresh(benchmark::State& state) {
  const auto& scans = kittiScans();
  std::size_t i = 0;
  for (auto _ : state) {
    ScanSegmenter segmenter(VoxelMapConfig{}, kittiSolver(state.range(0)));
    benchmark::DoNotOptimize(segmenter.segment(scans[i++ % scans.size()]).data());
  }
}
BENCHMARK(BM_KittiScanSegmentationFresh)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime();

// the per-point step of that segmentation alone (labelScanPoints, its buffers kept), on scan
// 000000's min-cut voxel labels
void BM_KittiScanPointLabels(benchmark::State& state) {
  const auto& points = kittiScans()[0];
  ScanSegmenter segmenter(VoxelMapConfig{}, GroundSegmentationConfig{});
  segmenter.segment(points);
  PointLabelBuffers buffers;
  std::vector<std::uint8_t> labels;
  for (auto _ : state) {
    labelScanPoints(segmenter.map(), points, segmenter.voxelOf(), segmenter.result().refined, segmenter.config(),
                    buffers, labels);
    benchmark::DoNotOptimize(labels.data());
  }
}
BENCHMARK(BM_KittiScanPointLabels)->Unit(benchmark::kMillisecond)->UseRealTime();

// the progressive morphological filter baseline on one real scan: ours (0, bucketed boxes) against
// PCL's octree (1), with the same labels
void BM_KittiScanMorphologicalFilter(benchmark::State& state) {
  static const rig::KittiScan scan =
      rig::readKittiScan(std::string(TERRAIN_SOURCE_DIR) + "/tests/data/semantickitti/000000.bin");
  const eval::MorphologicalFilterConfig cfg;
  for (auto _ : state) {
    benchmark::DoNotOptimize((state.range(0) == 0 ? eval::groundByMorphologicalFilter(scan.points, cfg)
                                                  : eval::groundByMorphologicalFilterPcl(scan.points, cfg))
                                 .data());
  }
}
BENCHMARK(BM_KittiScanMorphologicalFilter)->Arg(0)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(5);
BENCHMARK(BM_KittiScanMorphologicalFilter)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1);

// decoding one second of HDL-64E traffic (10 sweeps, every laser returning)
void BM_PacketDecode(benchmark::State& state) {
  static const auto packets = [] {
    const rig::LaserCalibration lasers =
        rig::loadLaserCalibration(std::string(TERRAIN_SOURCE_DIR) + "/data/calibration/hdl64e_s2.1-sztaki.yaml");
    const int n = 2083;
    rig::velodyne::PacketEncoder encoder(lasers, n);
    std::vector<rig::velodyne::TimedPacket> out;
    for (int k = 0; k < 10; ++k) {
      LidarSweep sweep;
      sweep.start_time = 0.1 * k;
      sweep.end_time = sweep.start_time + 0.1;
      for (int j = 0; j < n; ++j) {
        const double a = rig::velodyne::stepToRadians(rig::velodyne::encoderStep(j, n));
        for (const auto& l : lasers.lasers) {
          Vector3 o, d;
          rig::laserRay(l, a, o, d);
          const Vector3 p = o + (5.0 + 0.37 * l.id + 0.01 * (j % 97)) * d;
          sweep.points.push_back({static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z()),
                                  50.0f, static_cast<std::uint16_t>(l.id), static_cast<float>(a),
                                  sweep.start_time + 0.1 * j / n});
        }
      }
      encoder.addSweep(sweep, out);
    }
    return out;
  }();
  static const rig::LaserCalibration lasers =
      rig::loadLaserCalibration(std::string(TERRAIN_SOURCE_DIR) + "/data/calibration/hdl64e_s2.1-sztaki.yaml");
  for (auto _ : state) {
    rig::velodyne::SweepAssembler a(lasers);
    std::vector<LidarSweep> sweeps;
    for (const auto& p : packets) a.push(p.payload.data(), p.payload.size(), sweeps);
    benchmark::DoNotOptimize(sweeps.data());
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(packets.size()));
}
BENCHMARK(BM_PacketDecode)->Unit(benchmark::kMillisecond)->UseRealTime();

// `frames` frames of the urban scene through the pipeline as 'terrain run' drives it: the simulated
// rig on one thread feeding the pipeline on another through a bounded queue; the per-frame records
std::vector<FrameRecord> streamUrban(int frames) {
  static const auto world = [] {
    urbanWorld();  // writes the scene
    return std::make_shared<const sim::World>(fs::temp_directory_path() / "terrain_bench" / "urban_1.xml");
  }();
  sim::SimulatedRig rig(world, sim::SimConfig{}, frames);
  Pipeline pipeline(rig.calibration(), PipelineConfig{});
  app::BoundedQueue<SensorFrame> queue(4);
  std::thread sensing([&] {
    while (auto f = rig.next()) {
      if (!queue.push(std::move(f->sensors))) break;
    }
    queue.close();
  });
  while (auto f = queue.pop()) pipeline.process(*f);
  sensing.join();
  pipeline.finish();
  return pipeline.records();
}

// the whole pipeline in streaming mode over 40 frames of the urban scene (lidar and the default
// camera rig, four cameras at 640x480); the figure is each frame's processing time (pose to height recovery)
void BM_PipelineStreaming(benchmark::State& state) {
  std::vector<double> frame_ms;
  for (auto _ : state) {
    for (const auto& r : streamUrban(40)) frame_ms.push_back(r.total_ms);
  }
  std::sort(frame_ms.begin(), frame_ms.end());
  state.counters["frame_median_ms"] = frame_ms[frame_ms.size() / 2];
  state.counters["frame_p95_ms"] = frame_ms[static_cast<std::size_t>(0.95 * (frame_ms.size() - 1))];
}
BENCHMARK(BM_PipelineStreaming)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1);

// memory over a long run, as 'terrain run --frames 1000' drives the pipeline (without the
// evaluation's truth): the process's resident memory per voxel added after the first 100 frames, and
// its growth over the last 300 frames, when the robot stands at the end of its path (reached near
// frame 600) and only sensor noise adds a few voxels. Two to three minutes: scripts/bench runs it
// with --long.
void BM_LongRunMemory(benchmark::State& state) {
  for (auto _ : state) {
    const std::vector<FrameRecord> r = streamUrban(1000);
    if (r.size() < 200 || r[99].resident_bytes == 0) {
      state.SkipWithError("fewer than 200 frames, or resident memory unknown");
      break;
    }
    const double added = static_cast<double>(r.back().voxels - r[99].voxels);
    state.counters["bytes_per_added_voxel"] =
        added > 0 ? (static_cast<double>(r.back().resident_bytes) - static_cast<double>(r[99].resident_bytes)) / added
                  : 0.0;
    // the last 300 frames
    const std::size_t from = r.size() - 301;
    state.counters["standing_growth_mb"] =
        (static_cast<double>(r.back().resident_bytes) - static_cast<double>(r[from].resident_bytes)) / 1e6;
    state.counters["standing_new_voxels"] = static_cast<double>(r.back().voxels - r[from].voxels);
    state.counters["voxels"] = static_cast<double>(r.back().voxels);
    // boundary estimation and crown samples per frame, early and late in the run (the map grows)
    auto median_estimation = [&](std::size_t a, std::size_t b) {
      std::vector<double> t;
      for (std::size_t i = a; i < b; ++i) t.push_back(r[i].estimation_ms);
      std::sort(t.begin(), t.end());
      return t[t.size() / 2];
    };
    state.counters["estimation_first100_ms"] = median_estimation(0, 100);
    state.counters["estimation_last100_ms"] = median_estimation(r.size() - 100, r.size());
  }
}
BENCHMARK(BM_LongRunMemory)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1)->Repetitions(1);

// keeps the median of every benchmark for the summary table
class Collector : public benchmark::ConsoleReporter {
 public:
  std::map<std::string, Run> medians;
  void ReportRuns(const std::vector<Run>& runs) override {
    ConsoleReporter::ReportRuns(runs);
    for (const auto& r : runs) {
      if (r.run_type == Run::RT_Aggregate && r.aggregate_name == "median")
        medians[r.benchmark_name().substr(0, r.benchmark_name().rfind('_'))] = r;
      if (r.run_type == Run::RT_Iteration && r.repetitions <= 1) medians[r.benchmark_name()] = r;
    }
  }
};

double ms(const benchmark::BenchmarkReporter::Run& r) {
  return r.GetAdjustedRealTime() * (r.time_unit == benchmark::kMillisecond ? 1.0 : 1e-6);
}
double perSecond(const benchmark::BenchmarkReporter::Run& r) {
  auto it = r.counters.find("items_per_second");
  return it == r.counters.end() ? 0.0 : static_cast<double>(it->second);
}

// The summary: one row per figure, printed as a table and, with --markdown=FILE, written as a
// Markdown table.
struct Row {
  std::string figure, median, target, ratio;
};

std::string format(const char* fmt, double v) {
  char b[64];
  std::snprintf(b, sizeof b, fmt, v);
  return b;
}
std::string times(double v) { return v > 0 ? format("%.1fx", v) : ""; }

}  // namespace

int main(int argc, char** argv) {
  // --markdown=FILE is ours; the rest is Google Benchmark's
  std::string markdown;
  int kept = 1;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a.rfind("--markdown=", 0) == 0) {
      markdown = a.substr(11);
    } else {
      argv[kept++] = argv[i];
    }
  }
  argc = kept;
  benchmark::Initialize(&argc, argv);
  Collector c;
  benchmark::RunSpecifiedBenchmarks(&c);
  auto get = [&](const std::string& prefix) -> const benchmark::BenchmarkReporter::Run* {
    for (const auto& [name, run] : c.medians) {
      if (name.rfind(prefix, 0) == 0) return &run;
    }
    return nullptr;
  };
  std::vector<Row> rows;
  const auto count = [](const benchmark::BenchmarkReporter::Run& r, const char* name) {
    return std::to_string(static_cast<long>(r.counters.at(name)));
  };
  const auto* ref = get("BM_LidarRays_MjRay");
  for (const char* name : {"BM_LidarRays_Accelerated/1/", "BM_LidarRays_Accelerated/2/"}) {
    if (const auto* r = get(name)) {
      rows.push_back({std::string("lidar rays, ") + name[25] + " thread(s)", format("%.0f k/s", perSecond(*r) / 1e3),
                      ">= 1333 k/s", times(ref ? perSecond(*r) / perSecond(*ref) : 0.0)});
    }
  }
  if (ref)
    rows.push_back(
        {"lidar rays, brute-force mj_ray (baseline)", format("%.0f k/s", perSecond(*ref) / 1e3), "", "1.0x"});
  const auto* naive = get("BM_Segmentation_NaiveHashMap");
  if (const auto* r = get("BM_Segmentation/0")) {
    rows.push_back({"segmentation ICM (one call), " + count(*r, "voxels") + " voxels", format("%.1f ms", ms(*r)),
                    "<= 50 ms", times(naive ? ms(*naive) / ms(*r) : 0.0)});
    rows.push_back({"voxel map memory per voxel",
                    format("%.1f B", static_cast<double>(r->counters.at("bytes_per_voxel"))), "<= 64 B", ""});
  }
  if (const auto* r = get("BM_Segmentation/1"))
    rows.push_back({"segmentation min-cut, same map", format("%.1f ms", ms(*r)), "<= 250 ms",
                    times(naive ? ms(*naive) / ms(*r) : 0.0)});
  if (naive) rows.push_back({"segmentation, naive hash map (baseline)", format("%.1f ms", ms(*naive)), "", "1.0x"});
  if (const auto* r = get("BM_SegmentationIncremental"))
    rows.push_back(
        {"incremental update, " + count(*r, "new_voxels") + " new voxels", format("%.1f ms", ms(*r)), "<= 10 ms", ""});
  if (const auto* r = get("BM_VoxelInsert/1/")) {
    const auto* base = get("BM_VoxelInsert/0/");
    rows.push_back({"voxel insertion, one sweep of " + count(*r, "points") + " points", format("%.2f ms", ms(*r)), "",
                    times(base ? ms(*base) / ms(*r) : 0.0)});
    if (base)
      rows.push_back({"voxel insertion, std::unordered_map (baseline)", format("%.2f ms", ms(*base)), "", "1.0x"});
  }
  if (const auto* r = get("BM_CameraRender"))
    rows.push_back({"camera 640x480 (RGB, depth, segmentation)", format("%.1f f/s", perSecond(*r)), ">= 10 f/s", ""});
  if (const auto* r = get("BM_CameraRig"))
    rows.push_back(
        {"camera rig, " + count(*r, "cameras") + " cameras at 640x480", format("%.1f f/s", perSecond(*r)), "", ""});
  if (const auto* r = get("BM_PipelineStreaming")) {
    rows.push_back({"whole pipeline per frame, streaming (median)",
                    format("%.1f ms", static_cast<double>(r->counters.at("frame_median_ms"))), "<= 100 ms", ""});
    rows.push_back({"whole pipeline per frame, streaming (p95)",
                    format("%.1f ms", static_cast<double>(r->counters.at("frame_p95_ms"))), "", ""});
  }
  if (const auto* r = get("BM_KittiScanMorphologicalFilter/0/")) {
    const auto* pcl = get("BM_KittiScanMorphologicalFilter/1/");
    rows.push_back({"one real KITTI scan, morphological filter", format("%.1f ms", ms(*r)), "",
                    times(pcl ? ms(*pcl) / ms(*r) : 0.0)});
    if (pcl) rows.push_back({"the same by PCL's octree (baseline)", format("%.1f ms", ms(*pcl)), "", "1.0x"});
  }
  if (const auto* r = get("BM_PacketDecode")) {
    // the real sensor sends 20,833 firings/s, 6 a packet
    rows.push_back({"HDL-64E packets decoded into sweeps", format("%.0f k/s", perSecond(*r) / 1e3), ">= 3.5 k/s",
                    times(perSecond(*r) / (20833.3 / 6))});
  }
  if (const auto* r = get("BM_LongRunMemory"); r && r->counters.count("voxels")) {
    rows.push_back({"1000 frames: resident memory per added voxel (" + count(*r, "voxels") + " voxels)",
                    format("%.1f B", static_cast<double>(r->counters.at("bytes_per_added_voxel"))), "", ""});
    rows.push_back({"1000 frames: growth over the last 300, " + count(*r, "standing_new_voxels") + " new voxels",
                    format("%.2f MB", static_cast<double>(r->counters.at("standing_growth_mb"))), "only with voxels",
                    ""});
    rows.push_back({"1000 frames: estimation, first / last 100",
                    format("%.1f", static_cast<double>(r->counters.at("estimation_first100_ms"))) + " / " +
                        format("%.1f ms", static_cast<double>(r->counters.at("estimation_last100_ms"))),
                    "", ""});
  }
  if (const auto* r = get("BM_KittiScanSegmentation/0"))
    rows.push_back(
        {"KITTI scans 000000 / 000020 in turn, segmentation, ICM", format("%.1f ms", ms(*r)), "<= 10 ms", ""});
  if (const auto* r = get("BM_KittiScanSegmentation/1"))
    rows.push_back(
        {"KITTI scans 000000 / 000020 in turn, segmentation, min-cut", format("%.1f ms", ms(*r)), "<= 10 ms", ""});
  if (const auto* r = get("BM_KittiScanSegmentationFresh/1"))
    rows.push_back({"the same, min-cut, a segmenter made for each scan", format("%.1f ms", ms(*r)), "", ""});
  if (const auto* r = get("BM_KittiScanPointLabels"))
    rows.push_back({"KITTI scan 000000, of which the per-point step", format("%.1f ms", ms(*r)), "", ""});

  std::printf("\n%-60s %16s %16s %12s\n", "figure", "median", "target", "vs baseline");
  for (const Row& r : rows)
    std::printf("%-60s %16s %16s %12s\n", r.figure.c_str(), r.median.c_str(), r.target.c_str(), r.ratio.c_str());
  if (!markdown.empty()) {
    std::ofstream out(markdown);
    out << "| figure | median | target | vs baseline |\n| --- | --- | --- | --- |\n";
    for (const Row& r : rows)
      out << "| " << r.figure << " | " << r.median << " | " << r.target << " | " << r.ratio << " |\n";
    if (!out.good()) {
      std::fprintf(stderr, "terrain_bench: error: cannot write %s\n", markdown.c_str());
      return 2;
    }
  }
  return 0;
}
