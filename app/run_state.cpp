#include "app/run_state.hpp"

#include "app/pipeline_config_io.hpp"
#include "rig/dataset.hpp"
#include "rig/file_io.hpp"
#include "scenes/scene_truth.hpp"

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>
#include <type_traits>

namespace terrain::app {

namespace fs = std::filesystem;

namespace {

constexpr char kMagic[] = "terrain-run-state/6\n";

// little-endian machine layout of plain values, appended to a byte string
class Out {
 public:
  template <typename T>
  void put(T v) {
    static_assert(std::is_trivially_copyable_v<T>);
    bytes.append(reinterpret_cast<const char*>(&v), sizeof v);
  }
  template <typename T>
  void putAll(const std::vector<T>& v) {
    put<std::uint64_t>(v.size());
    bytes.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
  }
  std::string bytes = kMagic;
};

// reads back what Out wrote; anything cut short or implausible is an InputError naming the file
class In {
 public:
  In(std::string bytes, std::string origin) : bytes_(std::move(bytes)), origin_(std::move(origin)) {
    const std::size_t m = std::strlen(kMagic);
    if (bytes_.compare(0, m, kMagic) != 0)
      throw io::InputError(origin_ + ": not a terrain run state (" + kRunStateFormat + ")");
    pos_ = m;
  }
  template <typename T>
  T get(const char* what) {
    T v;
    need(sizeof v, what);
    std::memcpy(&v, bytes_.data() + pos_, sizeof v);
    pos_ += sizeof v;
    return v;
  }
  template <typename T>
  std::vector<T> getAll(const char* what) {
    const auto n = get<std::uint64_t>(what);
    if (n > (bytes_.size() - pos_) / sizeof(T))
      fail(std::string(what) + ": " + std::to_string(n) + " entries do not fit in the file");
    std::vector<T> v(static_cast<std::size_t>(n));
    std::memcpy(v.data(), bytes_.data() + pos_, v.size() * sizeof(T));
    pos_ += v.size() * sizeof(T);
    return v;
  }
  std::uint64_t count(const char* what, std::size_t min_entry_bytes) {
    const auto n = get<std::uint64_t>(what);
    if (n > (bytes_.size() - pos_) / std::max<std::size_t>(min_entry_bytes, 1)) {
      fail(std::string(what) + ": " + std::to_string(n) + " entries do not fit in the file");
    }
    return n;
  }
  void end() {
    if (pos_ != bytes_.size()) fail(std::to_string(bytes_.size() - pos_) + " bytes left over after the last section");
  }
  [[noreturn]] void fail(const std::string& what) const { throw io::InputError(origin_ + ": " + what); }

 private:
  void need(std::size_t n, const char* what) {
    if (bytes_.size() - pos_ < n) fail(std::string("cut short while reading ") + what);
  }
  std::string bytes_, origin_;
  std::size_t pos_ = 0;
};

// the plain fields of records and voxels, written field by field (no padding bytes in the file)
void putVoxel(Out& o, const Voxel& v) {
  o.put<std::int32_t>(v.index.x()), o.put<std::int32_t>(v.index.y()), o.put<std::int32_t>(v.index.z());
  o.put(v.hits), o.put(v.height), o.put(v.r), o.put(v.g), o.put(v.b);
  o.put<std::uint8_t>(v.coloured), o.put<std::uint8_t>(static_cast<std::uint8_t>(v.label)), o.put(v.frame);
}
Voxel getVoxel(In& in) {
  Voxel v;
  const auto x = in.get<std::int32_t>("voxel"), y = in.get<std::int32_t>("voxel"), z = in.get<std::int32_t>("voxel");
  v.index = VoxelIndex(x, y, z);
  v.hits = in.get<std::uint32_t>("voxel"), v.height = in.get<float>("voxel");
  v.r = in.get<std::uint8_t>("voxel"), v.g = in.get<std::uint8_t>("voxel"), v.b = in.get<std::uint8_t>("voxel");
  v.coloured = in.get<std::uint8_t>("voxel") != 0;
  const auto label = in.get<std::uint8_t>("voxel");
  if (label > 2) in.fail("voxel label " + std::to_string(label) + " is not 0, 1 or 2");
  v.label = static_cast<VoxelLabel>(label);
  v.frame = in.get<std::uint32_t>("voxel");
  return v;
}
constexpr std::size_t kVoxelBytes = 3 * 4 + 4 + 4 + 3 + 1 + 1 + 4;

void putRecord(Out& o, const FrameRecord& r) {
  o.put<std::int32_t>(r.frame), o.put(r.time);
  for (double t : {r.pose_ms, r.voxel_ms, r.mesh_ms, r.segmentation_ms, r.boundary_ms, r.estimation_ms, r.total_ms})
    o.put(t);
  o.put<std::uint64_t>(r.points), o.put<std::uint64_t>(r.new_voxels), o.put<std::uint64_t>(r.voxels);
  o.put<std::int32_t>(r.estimated_vertices);
  o.put(r.position.x()), o.put(r.position.y()), o.put(r.position.z());
  o.put(r.attitude.w()), o.put(r.attitude.x()), o.put(r.attitude.y()), o.put(r.attitude.z());
}
FrameRecord getRecord(In& in) {
  FrameRecord r;
  r.frame = in.get<std::int32_t>("record"), r.time = in.get<double>("record");
  for (double* t :
       {&r.pose_ms, &r.voxel_ms, &r.mesh_ms, &r.segmentation_ms, &r.boundary_ms, &r.estimation_ms, &r.total_ms}) {
    *t = in.get<double>("record");
  }
  r.points = in.get<std::uint64_t>("record"), r.new_voxels = in.get<std::uint64_t>("record"),
  r.voxels = in.get<std::uint64_t>("record");
  r.estimated_vertices = in.get<std::int32_t>("record");
  const double x = in.get<double>("record"), y = in.get<double>("record"), z = in.get<double>("record");
  r.position = Point3(x, y, z);
  const double qw = in.get<double>("record"), qx = in.get<double>("record"), qy = in.get<double>("record"),
               qz = in.get<double>("record");
  const Rotation q(qw, qx, qy, qz);
  if (!std::isfinite(q.norm()) || std::abs(q.norm() - 1) > 1e-6) in.fail("record attitude is not a unit quaternion");
  r.attitude = q;
  return r;
}

// the file of a kept camera image: frame, camera name, what it is
std::string cameraName(int frame, const std::string& camera, const char* what) {
  char name[48];
  std::snprintf(name, sizeof name, "%06d_", frame);
  return name + camera + "_" + what + ".png";
}

}  // namespace

namespace {

// the scene's files (the MJCF, its truth sidecar, its heightfield when there is one) and a 64-bit
// FNV-1a digest of each: 'evaluate' refuses to score a run against a scene changed since
std::map<std::string, std::string> sceneDigests(const fs::path& scene) {
  std::map<std::string, std::string> out;
  fs::path hfield = scene;
  hfield.replace_extension(".hfield");
  for (const fs::path& f : {scene, scenes::truthPathFor(scene), hfield}) {
    if (!fs::exists(f)) continue;
    std::uint64_t h = 1469598103934665603ull;
    for (const char c : io::readFile(f)) {
      h ^= static_cast<unsigned char>(c);
      h *= 1099511628211ull;
    }
    char hex[17];
    std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(h));
    out[f.filename().string()] = hex;
  }
  return out;
}

}  // namespace

void writeRunState(const fs::path& out, const Pipeline& pipeline, const eval::RunTruth& truth, const fs::path& scene) {
  const fs::path dir = out / "state";
  fs::create_directories(dir / "cameras");
  // the pipeline's final state
  Out p;
  p.put<std::uint64_t>(pipeline.map().size());
  for (const auto& v : pipeline.map().voxels()) putVoxel(p, v);
  p.put<std::uint64_t>(pipeline.mesh().vertices().size());
  for (const auto& m : pipeline.mesh().vertices()) {
    p.put<std::int32_t>(m.cell.x()), p.put<std::int32_t>(m.cell.y()), p.put(m.top_voxel);
    p.put(m.sensed_height), p.put(m.recovered_height), p.put(m.ceiling), p.put<std::uint8_t>(m.spread),
        p.put<std::uint8_t>(m.parallax);
    p.putAll(m.estimates);
    for (std::uint16_t n : m.outcomes) p.put(n);
  }
  const SegmentationResult& s = pipeline.segmentation();
  p.putAll(s.rough), p.putAll(s.refined), p.putAll(s.ground_height);
  p.put(s.energy_rough), p.put(s.energy_refined), p.put<std::int32_t>(s.iterations), p.put<std::int32_t>(s.tiles);
  p.put<std::uint64_t>(pipeline.records().size());
  for (const auto& r : pipeline.records()) putRecord(p, r);
  const std::vector<CrownRecord> crowns = pipeline.crownRecords();
  p.put<std::uint64_t>(crowns.size());
  for (const auto& c : crowns) {
    p.put(c.key), p.put(c.centre.x()), p.put(c.centre.y());
    for (std::uint16_t n : c.outcomes) p.put(n);
    p.put(static_cast<std::uint8_t>(c.verdict));
  }
  // the truth beside it
  Out t;
  t.put<double>(truth.voxels.voxelSize());
  t.put<std::uint64_t>(truth.voxels.allVotes().size());
  for (const auto& [key, votes] : truth.voxels.allVotes()) t.put(key), t.put(votes.first), t.put(votes.second);
  t.put<std::uint64_t>(truth.path.size());
  for (const auto& q : truth.path) t.put(q.x()), t.put(q.y()), t.put(q.z());
  t.put<std::uint64_t>(truth.cameras.size());
  for (const auto& c : truth.cameras) {
    t.put<std::int32_t>(c.frame);
    t.put<std::int32_t>(c.camera);
    const std::string& camera = pipeline.calibration().cameras.at(c.camera).name;
    const Eigen::Matrix4d m = c.world_from_camera.matrix();
    for (int i = 0; i < 16; ++i) t.put(m(i / 4, i % 4));
    io::writeFileAtomic(
        dir / "cameras" / cameraName(c.frame, camera, "rgb"),
        [&] {
          std::vector<unsigned char> png;
          cv::Mat bgr;
          cv::cvtColor(c.rgb, bgr, cv::COLOR_RGB2BGR);
          cv::imencode(".png", bgr, png);
          return std::string(png.begin(), png.end());
        }(),
        true);
    io::writeFileAtomic(
        dir / "cameras" / cameraName(c.frame, camera, "seg"),
        [&] {
          std::vector<unsigned char> png;
          cv::imencode(".png", c.segmentation, png);
          return std::string(png.begin(), png.end());
        }(),
        true);
  }
  nlohmann::json j;
  j["format"] = kRunStateFormat;
  const fs::path abs_scene = fs::absolute(scene).lexically_normal(), abs_out = fs::absolute(out).lexically_normal();
  const fs::path rel = abs_scene.lexically_relative(abs_out);
  j["scene"] = (!rel.empty() && *rel.begin() != "..") ? rel.string() : abs_scene.string();
  j["scene_relative_to_run"] = !rel.empty() && *rel.begin() != "..";
  j["scene_files"] = sceneDigests(scene);
  j["frames"] = pipeline.records().size();
  j["voxels"] = pipeline.map().size();
  j["calibration"] = nlohmann::json::parse(rig::calibrationToJson(pipeline.calibration()));
  io::writeFileAtomic(dir / "pipeline_config.json", pipelineConfigToJson(pipeline.config()) + "\n", true);
  io::writeFileAtomic(dir / "pipeline.bin", p.bytes, true);
  io::writeFileAtomic(dir / "truth.bin", t.bytes, true);
  // last: a state without state.json is incomplete
  io::writeFileAtomic(dir / "state.json", j.dump(1) + "\n", true);
}

SavedRun readRunState(const fs::path& out) {
  const fs::path dir = out / "state";
  const fs::path state_file = dir / "state.json";
  if (!fs::exists(state_file)) {
    throw io::InputError(
        state_file.string() +
        ": missing (not a run directory of 'terrain run' or 'terrain reconstruct', or an unfinished one)");
  }
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(io::readFile(state_file));
  } catch (const nlohmann::json::exception& e) {
    throw io::InputError(state_file.string() + ": not valid JSON (" + e.what() + ")");
  }
  if (!j.is_object() || j.value("format", "") != kRunStateFormat) {
    throw io::InputError(state_file.string() + ": format is not " + std::string(kRunStateFormat));
  }
  if (!j.contains("scene") || !j["scene"].is_string() || !j.contains("calibration")) {
    throw io::InputError(state_file.string() + ": 'scene' or 'calibration' is missing");
  }
  SavedRun run;
  run.scene = j["scene"].get<std::string>();
  if (j.value("scene_relative_to_run", false)) run.scene = out / run.scene;
  // the scene must be the one the run ran in (states written before digests were kept have none)
  if (j.contains("scene_files") && j["scene_files"].is_object() && fs::exists(run.scene)) {
    const auto now = sceneDigests(run.scene);
    for (auto it = j["scene_files"].begin(); it != j["scene_files"].end(); ++it) {
      const fs::path file = run.scene.parent_path() / it.key();
      const auto found = now.find(it.key());
      if (found == now.end()) throw io::InputError(file.string() + ": the run's scene file is no longer there");
      if (!it.value().is_string() || found->second != it.value().get<std::string>()) {
        throw io::InputError(file.string() + ": changed since the run (it no longer matches what " +
                             state_file.string() + " recorded); run again to score the new scene");
      }
    }
  }
  const RigCalibration calibration =
      rig::calibrationFromJson(j["calibration"].dump(), state_file.string() + " (calibration)");
  PipelineConfig config;
  loadPipelineConfig(dir / "pipeline_config.json", config);
  try {
    validate(config);
  } catch (const io::InputError& e) {
    throw io::InputError((dir / "pipeline_config.json").string() + ": " + e.what());
  }

  // the pipeline's final state
  const fs::path pipeline_file = dir / "pipeline.bin";
  In p(io::readFile(pipeline_file), pipeline_file.string());
  std::vector<Voxel> voxels(static_cast<std::size_t>(p.count("voxels", kVoxelBytes)));
  for (auto& v : voxels) v = getVoxel(p);
  std::vector<MeshVertex> vertices(static_cast<std::size_t>(p.count("mesh vertices", 34 + 2 * kEstimateOutcomes)));
  for (auto& m : vertices) {
    const auto x = p.get<std::int32_t>("mesh vertex"), y = p.get<std::int32_t>("mesh vertex");
    m.cell = CellIndex(x, y);
    m.top_voxel = p.get<std::uint32_t>("mesh vertex");
    m.sensed_height = p.get<float>("mesh vertex"), m.recovered_height = p.get<float>("mesh vertex");
    m.ceiling = p.get<float>("mesh vertex");
    if (std::isnan(m.ceiling)) p.fail("a mesh vertex's ceiling is NaN");
    m.spread = p.get<std::uint8_t>("mesh vertex") != 0;
    m.parallax = p.get<std::uint8_t>("mesh vertex") != 0;
    m.estimates = p.getAll<HeightEstimate>("mesh vertex estimates");
    for (std::uint16_t& n : m.outcomes) n = p.get<std::uint16_t>("mesh vertex outcomes");
  }
  SegmentationResult s;
  s.rough = p.getAll<std::uint8_t>("rough labels");
  s.refined = p.getAll<std::uint8_t>("refined labels");
  s.ground_height = p.getAll<float>("ground heights");
  s.energy_rough = p.get<double>("energies"), s.energy_refined = p.get<double>("energies");
  s.iterations = p.get<std::int32_t>("segmentation"), s.tiles = p.get<std::int32_t>("segmentation");
  std::vector<FrameRecord> records(static_cast<std::size_t>(p.count("records", 152)));
  for (auto& r : records) r = getRecord(p);
  std::vector<CrownRecord> crowns(static_cast<std::size_t>(p.count("crown records", 13 + 2 * kCrownOutcomes)));
  for (auto& c : crowns) {
    c.key = p.get<std::uint32_t>("crown record");
    const float x = p.get<float>("crown record"), y = p.get<float>("crown record");
    c.centre = Eigen::Vector2f(x, y);
    for (std::uint16_t& n : c.outcomes) n = p.get<std::uint16_t>("crown record outcomes");
    const auto verdict = p.get<std::uint8_t>("crown record verdict");
    if (verdict > static_cast<std::uint8_t>(CrownVerdict::RaisedFromColumns))
      p.fail("crown record verdict " + std::to_string(verdict) + " is unknown");
    c.verdict = static_cast<CrownVerdict>(verdict);
  }
  p.end();
  run.pipeline = std::make_unique<Pipeline>(calibration, config);
  if (!run.pipeline->restore(std::move(voxels), std::move(vertices), std::move(s), std::move(records), crowns)) {
    p.fail(
        "voxels, mesh and labels do not fit together (duplicate voxels or cells, a voxel index beyond +-1 M, labels "
        "not one per voxel, or a vertex's top voxel out of range)");
  }

  // the truth
  const fs::path truth_file = dir / "truth.bin";
  In t(io::readFile(truth_file), truth_file.string());
  const double voxel_size = t.get<double>("voxel size");
  if (!(voxel_size > 0) || std::abs(voxel_size - config.voxel_map.voxel_size) > 1e-9) {
    t.fail("truth voxel size " + std::to_string(voxel_size) + " m differs from the pipeline's");
  }
  run.truth = std::make_unique<eval::RunTruth>(voxel_size);
  const auto votes = t.count("voxel votes", 16);
  for (std::uint64_t i = 0; i < votes; ++i) {
    const auto key = t.get<std::uint64_t>("voxel votes");
    const auto g = t.get<std::uint32_t>("voxel votes"), n = t.get<std::uint32_t>("voxel votes");
    run.truth->voxels.addVotes(key, g, n);
  }
  run.truth->path.resize(static_cast<std::size_t>(t.count("path", 24)));
  for (auto& q : run.truth->path) {
    const double x = t.get<double>("path"), y = t.get<double>("path"), z = t.get<double>("path");
    q = Point3(x, y, z);
  }
  run.truth->cameras.resize(static_cast<std::size_t>(t.count("cameras", 136)));
  for (auto& c : run.truth->cameras) {
    c.frame = t.get<std::int32_t>("camera");
    c.camera = t.get<std::int32_t>("camera");
    if (c.camera < 0 || c.camera >= static_cast<int>(calibration.cameras.size()))
      t.fail("camera index " + std::to_string(c.camera) + " is not one of the calibration's " +
             std::to_string(calibration.cameras.size()) + " cameras");
    const std::string& camera = calibration.cameras[c.camera].name;
    Eigen::Matrix4d m;
    for (int i = 0; i < 16; ++i) m(i / 4, i % 4) = t.get<double>("camera pose");
    c.world_from_camera.matrix() = m;
    const fs::path rgb = dir / "cameras" / cameraName(c.frame, camera, "rgb"),
                   seg = dir / "cameras" / cameraName(c.frame, camera, "seg");
    cv::Mat bgr = cv::imread(rgb.string(), cv::IMREAD_COLOR);
    c.segmentation = cv::imread(seg.string(), cv::IMREAD_UNCHANGED);
    if (bgr.empty()) throw io::InputError(rgb.string() + ": missing or not an image");
    if (c.segmentation.empty() || c.segmentation.type() != CV_16UC1 || c.segmentation.size() != bgr.size()) {
      throw io::InputError(seg.string() + ": missing, or not a 16-bit segmentation image the size of the camera image");
    }
    cv::cvtColor(bgr, c.rgb, cv::COLOR_BGR2RGB);
  }
  t.end();
  return run;
}

}  // namespace terrain::app
