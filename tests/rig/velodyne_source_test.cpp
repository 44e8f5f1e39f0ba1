#include "rig/velodyne_source.hpp"

#include "rig/file_io.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <string>

namespace terrain::rig {
namespace {

std::string errorOf(const std::string& text, const std::string& role = "lidar source") {
  try {
    LidarEndpoint::parse(text, role);
  } catch (const io::InputError& e) {
    return e.what();
  }
  return "";
}

TEST(LidarEndpointTest, LocalhostIsTheLoopbackAddress) {
  const LidarEndpoint e = LidarEndpoint::parse("udp:localhost:2370");
  EXPECT_EQ(e.kind, LidarEndpoint::Kind::Udp);
  EXPECT_EQ(e.host, "localhost");
  EXPECT_EQ(e.port, 2370);
  // a packet sent to localhost arrives at a receiver bound there
  UdpReceiver receiver("localhost", 0);
  UdpSender sender("localhost", receiver.port());
  const std::uint8_t packet[4] = {1, 2, 3, 4};
  sender.send(packet, sizeof packet);
  std::uint8_t buffer[16];
  EXPECT_EQ(receiver.receive(buffer, sizeof buffer, std::chrono::milliseconds(2000)), 4);
  EXPECT_EQ(buffer[3], 4);
}

TEST(LidarEndpointTest, BadEndpointsAreNamedWithTheirRole) {
  EXPECT_EQ(errorOf("udp:lidar.local:2368"),
            "lidar source 'udp:lidar.local:2368': 'lidar.local' is not an IPv4 address (nor localhost)");
  EXPECT_EQ(errorOf("udp:127.0.0.1:port", "stream destination"),
            "stream destination 'udp:127.0.0.1:port': port 'port' is not a number in [0, 65535]");
  EXPECT_NE(errorOf("tcp:1.2.3.4:1").find("expected pcap:FILE or udp:HOST:PORT"), std::string::npos);
}

TEST(LidarEndpointTest, ASecondReceiverOnTheSamePortIsRefused) {
  UdpReceiver first("127.0.0.1", 0);
  try {
    UdpReceiver second("127.0.0.1", first.port());
    FAIL() << "two receivers bound port " << first.port();
  } catch (const io::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("another program receives on that port"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace terrain::rig
