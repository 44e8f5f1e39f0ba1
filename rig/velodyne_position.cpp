#include "rig/velodyne_position.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <sstream>

namespace terrain::rig::velodyne {

namespace {

std::vector<std::string> splitFields(const std::string& s) {
  std::vector<std::string> out;
  std::string cur;
  for (char c : s) {
    if (c == ',') {
      out.push_back(cur);
      cur.clear();
    } else {
      cur += c;
    }
  }
  out.push_back(cur);
  return out;
}

bool toDouble(const std::string& s, double& v) {
  if (s.empty()) return false;
  char* end = nullptr;
  v = std::strtod(s.c_str(), &end);
  return end == s.c_str() + s.size() && std::isfinite(v);
}

// ddmm.mmmm (latitude) or dddmm.mmmm (longitude) and a hemisphere letter, to degrees
bool angle(const std::string& value, const std::string& hemisphere, double limit, double& deg) {
  double v = 0;
  if (!toDouble(value, v) || v < 0) return false;
  const double whole = std::floor(v / 100.0);
  const double minutes = v - whole * 100.0;
  if (minutes >= 60.0) return false;
  deg = whole + minutes / 60.0;
  if (hemisphere == "S" || hemisphere == "W") {
    deg = -deg;
  } else if (hemisphere != "N" && hemisphere != "E") {
    return false;
  }
  return std::abs(deg) <= limit;
}

// hhmmss(.sss) to seconds since midnight: six digits, then nothing or a point and digits
bool timeOfDay(const std::string& s, double& t) {
  const bool digits6 = s.size() >= 6 && s.find_first_not_of("0123456789") >= 6;
  const bool fraction = s.size() == 6 || (s[6] == '.' && s.find_first_not_of("0123456789", 7) == std::string::npos);
  if (!digits6 || !fraction) return false;
  const int hh = std::atoi(s.substr(0, 2).c_str()), mm = std::atoi(s.substr(2, 2).c_str());
  double ss = 0;
  if (!toDouble(s.substr(4), ss)) return false;
  if (hh > 23 || mm > 59 || ss >= 61.0) return false;
  t = hh * 3600.0 + mm * 60.0 + ss;
  return true;
}

// days since 1970-01-01 of a civil date (proleptic Gregorian)
long long daysFromCivil(int y, int m, int d) {
  y -= m <= 2;
  const int era = (y >= 0 ? y : y - 399) / 400;
  const int yoe = y - era * 400;
  const int doy = (153 * (m + (m > 2 ? -3 : 9)) + 2) / 5 + d - 1;
  const int doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
  return static_cast<long long>(era) * 146097 + doe - 719468;
}

std::uint32_t get32(const std::uint8_t* p) {
  return static_cast<std::uint32_t>(p[0]) | (static_cast<std::uint32_t>(p[1]) << 8) |
         (static_cast<std::uint32_t>(p[2]) << 16) | (static_cast<std::uint32_t>(p[3]) << 24);
}

std::string withChecksum(const std::string& body) {
  unsigned sum = 0;
  for (char c : body) sum ^= static_cast<unsigned char>(c);
  char tail[8];
  std::snprintf(tail, sizeof tail, "*%02X", sum);
  return "$" + body + tail;
}

}  // namespace

std::optional<NmeaFix> parseNmea(const std::string& sentence, std::string* why) {
  const auto fail = [why](const std::string& reason) -> std::optional<NmeaFix> {
    if (why) *why = reason;
    return std::nullopt;
  };
  std::string s = sentence;
  while (!s.empty() && (s.back() == '\n' || s.back() == '\r' || s.back() == '\0')) s.pop_back();
  if (s.size() < 7 || s[0] != '$') return fail("not an NMEA sentence (no leading '$')");
  // the checksum: XOR of everything between '$' and '*'
  std::string body = s.substr(1);
  const auto star = body.find('*');
  if (star != std::string::npos) {
    unsigned sum = 0;
    for (std::size_t i = 0; i < star; ++i) sum ^= static_cast<unsigned char>(body[i]);
    const std::string given = body.substr(star + 1);
    char* end = nullptr;
    const unsigned long stated = std::strtoul(given.c_str(), &end, 16);
    if (given.size() != 2 || end != given.c_str() + 2) return fail("checksum '" + given + "' is not two hex digits");
    if (stated != sum) {
      char m[64];
      std::snprintf(m, sizeof m, "checksum %02lX does not match the sentence's %02X", stated, sum);
      return fail(m);
    }
    body = body.substr(0, star);
  }
  const std::vector<std::string> f = splitFields(body);
  if (f[0].size() != 5) return fail("sentence type '" + f[0] + "' is not a talker and a type");
  NmeaFix fix;
  const std::string kind = f[0].substr(2);
  fix.type = "GP" + kind;
  if (kind == "RMC") {
    // $GPRMC,hhmmss.ss,A,llll.ll,a,yyyyy.yy,a,speed(knots),course,ddmmyy,...
    if (f.size() < 10) return fail("RMC sentence with " + std::to_string(f.size()) + " fields, fewer than 10");
    if (!timeOfDay(f[1], fix.time_of_day)) return fail("RMC time '" + f[1] + "' is not hhmmss");
    fix.valid = f[2] == "A";
    if (fix.valid) {
      if (!angle(f[3], f[4], 90.0, fix.latitude_deg))
        return fail("RMC latitude '" + f[3] + "," + f[4] + "' is not ddmm.mm,N|S");
      if (!angle(f[5], f[6], 180.0, fix.longitude_deg))
        return fail("RMC longitude '" + f[5] + "," + f[6] + "' is not dddmm.mm,E|W");
    }
    double knots = 0;
    if (toDouble(f[7], knots)) fix.speed_mps = knots * 1852.0 / 3600.0;
    const std::string& date = f[9];
    if (date.size() == 6 && date.find_first_not_of("0123456789") == std::string::npos) {
      const int dd = std::atoi(date.substr(0, 2).c_str()), mo = std::atoi(date.substr(2, 2).c_str());
      const int yy = std::atoi(date.substr(4, 2).c_str());
      if (dd >= 1 && dd <= 31 && mo >= 1 && mo <= 12) {
        // two-digit years: 1980-2079 (GPS time starts in 1980)
        const int year = yy < 80 ? 2000 + yy : 1900 + yy;
        fix.epoch = static_cast<double>(daysFromCivil(year, mo, dd)) * 86400.0 + fix.time_of_day;
      }
    }
    if (!fix.epoch) return fail("RMC date '" + date + "' is not ddmmyy");
    return fix;
  }
  if (kind == "GGA") {
    // $GPGGA,hhmmss.ss,llll.ll,a,yyyyy.yy,a,quality,satellites,hdop,altitude,M,separation,M,...
    if (f.size() < 12) return fail("GGA sentence with " + std::to_string(f.size()) + " fields, fewer than 12");
    if (!timeOfDay(f[1], fix.time_of_day)) return fail("GGA time '" + f[1] + "' is not hhmmss");
    double quality = 0;
    fix.valid = toDouble(f[6], quality) && quality > 0;
    if (fix.valid) {
      if (!angle(f[2], f[3], 90.0, fix.latitude_deg))
        return fail("GGA latitude '" + f[2] + "," + f[3] + "' is not ddmm.mm,N|S");
      if (!angle(f[4], f[5], 180.0, fix.longitude_deg))
        return fail("GGA longitude '" + f[4] + "," + f[5] + "' is not dddmm.mm,E|W");
      double v = 0;
      if (toDouble(f[8], v) && v > 0) fix.hdop = v;
      double alt = 0, sep = 0;
      if (toDouble(f[9], alt)) fix.altitude_m = alt + (toDouble(f[11], sep) ? sep : 0.0);
    }
    return fix;
  }
  return fail("a " + f[0] + " sentence, neither RMC nor GGA");
}

std::optional<PositionPacket> parsePositionPacket(const std::uint8_t* data, std::size_t size, std::string* why) {
  if (size != kPositionPacketSize) {
    if (why) *why = std::to_string(size) + " bytes, not the 512 of a position packet";
    return std::nullopt;
  }
  PositionPacket p;
  p.timestamp_us = get32(data + 198);
  if (p.timestamp_us >= 3600000000u) {
    if (why) *why = "timestamp " + std::to_string(p.timestamp_us) + " us lies beyond the hour";
    return std::nullopt;
  }
  p.pps = data[202];
  for (std::size_t i = kNmeaOffset; i < size; ++i) {
    const char c = static_cast<char>(data[i]);
    if (c == '\0' || c == '\r' || c == '\n') break;
    p.nmea += c;
  }
  return p;
}

std::vector<std::uint8_t> positionPacket(std::uint32_t timestamp_us, const std::string& sentence, std::uint8_t pps) {
  std::vector<std::uint8_t> d(kPositionPacketSize, 0);
  for (int i = 0; i < 4; ++i) d[198 + i] = static_cast<std::uint8_t>((timestamp_us >> (8 * i)) & 0xFF);
  d[202] = pps;
  const std::string text = sentence + "\r\n";
  for (std::size_t i = 0; i < text.size() && kNmeaOffset + i < d.size(); ++i) {
    d[kNmeaOffset + i] = static_cast<std::uint8_t>(text[i]);
  }
  return d;
}

namespace {

// "dd" or "ddd" degrees and minutes with `decimals` decimals, as NMEA writes an angle's magnitude
std::string ddmm(double deg, int width, int decimals) {
  const double a = std::abs(deg);
  double whole = std::floor(a);
  double minutes = (a - whole) * 60.0;
  // minutes that round up to 60 carry into the degrees
  if (std::round(minutes * std::pow(10.0, decimals)) >= 60.0 * std::pow(10.0, decimals)) whole += 1, minutes = 0;
  char b[48];
  std::snprintf(b, sizeof b, "%0*d%0*.*f", width, static_cast<int>(whole), decimals + 3, decimals, minutes);
  return std::string(b);
}

// UTC time of day [s] of an epoch, and the date of its day
double utcTimeOfDay(double epoch, std::tm& date) {
  const double day = std::floor(epoch / 86400.0);
  const std::time_t t = static_cast<std::time_t>(day * 86400.0);
  gmtime_r(&t, &date);
  return epoch - day * 86400.0;
}

}  // namespace

std::string gpggaSentence(double epoch, double latitude_deg, double longitude_deg, double altitude_m, double hdop) {
  std::tm utc{};
  const double tod = utcTimeOfDay(epoch, utc);
  const int hh = static_cast<int>(tod / 3600), mm = static_cast<int>((tod - hh * 3600) / 60);
  const double ss = tod - hh * 3600 - mm * 60;
  char body[200];
  std::snprintf(body, sizeof body, "GPGGA,%02d%02d%06.3f,%s,%c,%s,%c,1,12,%.2f,%.3f,M,0.000,M,,", hh, mm, ss,
                ddmm(latitude_deg, 2, 7).c_str(), latitude_deg < 0 ? 'S' : 'N', ddmm(longitude_deg, 3, 7).c_str(),
                longitude_deg < 0 ? 'W' : 'E', hdop, altitude_m);
  return withChecksum(body);
}

std::string gprmcSentence(double epoch, double latitude_deg, double longitude_deg, double speed_mps, bool valid) {
  std::tm utc{};
  const double tod = utcTimeOfDay(epoch, utc);
  const int hh = static_cast<int>(tod / 3600), mm = static_cast<int>((tod - hh * 3600) / 60);
  const double ss = tod - hh * 3600 - mm * 60;
  const auto ddmm4 = [](double deg, int width) { return ddmm(deg, width, 4); };
  char body[160];
  std::snprintf(body, sizeof body, "GPRMC,%02d%02d%06.3f,%c,%s,%c,%s,%c,%.2f,0.0,%02d%02d%02d,,,A", hh, mm, ss,
                valid ? 'A' : 'V', ddmm4(latitude_deg, 2).c_str(), latitude_deg < 0 ? 'S' : 'N',
                ddmm4(longitude_deg, 3).c_str(), longitude_deg < 0 ? 'W' : 'E', speed_mps * 3600.0 / 1852.0,
                utc.tm_mday, utc.tm_mon + 1, utc.tm_year % 100);
  return withChecksum(body);
}

double timeBaseFromFix(std::uint32_t timestamp_us, double fix_epoch) {
  const double stamp = timestamp_us * 1e-6;
  return std::round((fix_epoch - stamp) / 3600.0) * 3600.0;
}

GpsFix gpsFix(const PositionPacket& packet, const NmeaFix& fix, double time_base) {
  GpsFix g;
  g.time = time_base + packet.timestamp_us * 1e-6;
  g.latitude_deg = fix.latitude_deg;
  g.longitude_deg = fix.longitude_deg;
  g.altitude_m = fix.altitude_m.value_or(0.0);
  g.sigma_m = fix.hdop ? 2.5 * *fix.hdop : 5.0;
  return g;
}

void PositionEncoder::add(const std::vector<GpsFix>& fixes, std::vector<TimedPosition>& out) {
  for (const GpsFix& f : fixes) {
    const double epoch = epoch_ + f.time;
    const auto stamp = static_cast<std::uint32_t>(std::llround(f.time * 1e6) % 3600000000LL);
    out.push_back({f.time, positionPacket(stamp, gpggaSentence(epoch, f.latitude_deg, f.longitude_deg, f.altitude_m,
                                                               f.sigma_m / 2.5))});
    if (std::floor(f.time) != last_rmc_second_) {
      last_rmc_second_ = std::floor(f.time);
      out.push_back({f.time, positionPacket(stamp, gprmcSentence(epoch, f.latitude_deg, f.longitude_deg))});
    }
  }
}

}  // namespace terrain::rig::velodyne
