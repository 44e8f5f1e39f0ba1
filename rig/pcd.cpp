#include "rig/pcd.hpp"

#include "rig/file_io.hpp"

#include <cstring>
#include <map>
#include <sstream>

namespace terrain::rig {

namespace {

struct Field {
  const char* name;
  int size;
  char type;
};

// record layout, packed, in file order
constexpr Field kFields[] = {{"x", 4, 'F'},         {"y", 4, 'F'},     {"z", 4, 'F'},
                             {"intensity", 4, 'F'}, {"ring", 2, 'U'},  {"azimuth", 4, 'F'},
                             {"time", 8, 'F'},      {"label", 4, 'I'}, {"class", 1, 'U'}};
constexpr int kRecordSize = 35;

template <typename T>
void put(char*& p, T v) {
  std::memcpy(p, &v, sizeof v);
  p += sizeof v;
}

}  // namespace

std::string encodePcd(const LidarSweep& sweep, const std::vector<PointTruth>& truth, bool truth_fields) {
  const std::size_t n = sweep.points.size();
  const std::size_t fields = truth_fields ? std::size(kFields) : std::size(kFields) - 2;  // label and class last
  const int record = truth_fields ? kRecordSize : kRecordSize - 5;
  std::ostringstream h;
  h << "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS";
  for (std::size_t i = 0; i < fields; ++i) h << ' ' << kFields[i].name;
  h << "\nSIZE";
  for (std::size_t i = 0; i < fields; ++i) h << ' ' << kFields[i].size;
  h << "\nTYPE";
  for (std::size_t i = 0; i < fields; ++i) h << ' ' << kFields[i].type;
  h << "\nCOUNT";
  for (std::size_t i = 0; i < fields; ++i) h << " 1";
  h << "\nWIDTH " << n << "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " << n << "\nDATA binary\n";
  std::string out = h.str();
  const std::size_t header = out.size();
  out.resize(header + n * record);
  char* p = out.data() + header;
  for (std::size_t i = 0; i < n; ++i) {
    const LidarPoint& q = sweep.points[i];
    const PointTruth t = truth.empty() ? PointTruth{} : truth[i];
    put(p, q.x), put(p, q.y), put(p, q.z), put(p, q.intensity), put(p, q.ring);
    put(p, q.azimuth), put(p, q.time);
    if (truth_fields) put(p, t.geom), put(p, t.cls);
  }
  return out;
}

DecodedPcd decodePcd(const std::string& bytes, const std::string& origin) {
  auto fail = [&](const std::string& what) -> void { throw io::InputError(origin + ": " + what); };
  // header: one keyword per line up to DATA
  std::vector<std::string> names;
  std::vector<int> sizes, counts;
  std::vector<char> types;
  long long points = -1;
  std::size_t pos = 0;
  int line_no = 0;
  std::string data_kind;
  while (pos < bytes.size()) {
    const std::size_t eol = bytes.find('\n', pos);
    if (eol == std::string::npos) fail("header ends before DATA");
    std::istringstream line(bytes.substr(pos, eol - pos));
    pos = eol + 1;
    ++line_no;
    std::string key;
    if (!(line >> key) || key[0] == '#') continue;
    if (key == "FIELDS") {
      for (std::string s; line >> s;) names.push_back(s);
    } else if (key == "SIZE") {
      for (int s; line >> s;) sizes.push_back(s);
    } else if (key == "TYPE") {
      for (char s; line >> s;) types.push_back(s);
    } else if (key == "COUNT") {
      for (int s; line >> s;) counts.push_back(s);
    } else if (key == "POINTS") {
      if (!(line >> points) || points < 0) fail("line " + std::to_string(line_no) + ": bad POINTS");
    } else if (key == "DATA") {
      line >> data_kind;
      break;
    }
  }
  if (data_kind != "binary") fail("DATA '" + data_kind + "' is not supported (binary PCD expected)");
  if (names.empty() || sizes.size() != names.size() || types.size() != names.size()) {
    fail("FIELDS, SIZE and TYPE must list the same number of entries");
  }
  if (counts.empty()) counts.assign(names.size(), 1);
  if (counts.size() != names.size()) fail("COUNT must list one entry per field");
  if (points < 0) fail("POINTS is missing");
  // offsets of the fields we know
  std::map<std::string, std::pair<int, int>> where;  // name -> (offset, size)
  int record = 0;
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (sizes[i] != 1 && sizes[i] != 2 && sizes[i] != 4 && sizes[i] != 8) fail("field '" + names[i] + "' has bad SIZE");
    where[names[i]] = {record, sizes[i]};
    record += sizes[i] * counts[i];
  }
  for (const auto& f : kFields) {
    auto it = where.find(f.name);
    if (it != where.end() && it->second.second != f.size) {
      fail("field '" + std::string(f.name) + "' has SIZE " + std::to_string(it->second.second) + ", expected " +
           std::to_string(f.size));
    }
  }
  for (const char* required : {"x", "y", "z"}) {
    if (!where.count(required)) fail(std::string("field '") + required + "' is missing");
  }
  const std::size_t need = static_cast<std::size_t>(points) * record;
  if (bytes.size() - pos < need) {
    fail("data is truncated: " + std::to_string(bytes.size() - pos) + " bytes for " + std::to_string(points) +
         " points of " + std::to_string(record) + " bytes");
  }
  DecodedPcd out;
  out.points.resize(points);
  const bool has_truth = where.count("label") > 0;
  if (has_truth) out.truth.resize(points);
  const char* base = bytes.data() + pos;
  auto read = [&](std::size_t i, const char* name, void* dst) {
    auto it = where.find(name);
    if (it == where.end()) return;
    std::memcpy(dst, base + i * record + it->second.first, it->second.second);
  };
  for (std::size_t i = 0; i < static_cast<std::size_t>(points); ++i) {
    LidarPoint& q = out.points[i];
    read(i, "x", &q.x), read(i, "y", &q.y), read(i, "z", &q.z), read(i, "intensity", &q.intensity);
    read(i, "ring", &q.ring), read(i, "azimuth", &q.azimuth), read(i, "time", &q.time);
    if (has_truth) read(i, "label", &out.truth[i].geom), read(i, "class", &out.truth[i].cls);
  }
  return out;
}

}  // namespace terrain::rig
