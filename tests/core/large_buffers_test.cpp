#include "core/large_buffers.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <memory>
#include <numeric>
#include <vector>

namespace terrain {
namespace {

// Growing a buffer keeps its elements in order and gives room for the size asked; the new
// elements of resizeLarge are value-initialised and assignLarge writes every one.
TEST(LargeBuffersTest, GrowingKeepsTheElementsAndMakesRoom) {
  std::vector<std::uint32_t> v(1000);
  std::iota(v.begin(), v.end(), 0u);
  const std::size_t n = 3 * kHugePageBytes / sizeof(std::uint32_t);
  reserveLarge(v, n);
  ASSERT_EQ(v.size(), 1000u);
  EXPECT_GE(v.capacity(), n);
  for (std::uint32_t i = 0; i < 1000; ++i) ASSERT_EQ(v[i], i);
  resizeLarge(v, n);
  ASSERT_EQ(v.size(), n);
  EXPECT_EQ(v[999], 999u);
  for (std::size_t i = 1000; i < n; ++i) ASSERT_EQ(v[i], 0u) << i;
  assignLarge(v, n + 5, 7u);
  ASSERT_EQ(v.size(), n + 5);
  for (std::size_t i = 0; i < n + 5; ++i) ASSERT_EQ(v[i], 7u) << i;
}

// A buffer with room enough keeps its block: a workspace reused from call to call is not
// reallocated.
TEST(LargeBuffersTest, ABufferWithRoomKeepsItsBlock) {
  std::vector<float> v;
  v.reserve(5000);
  v.assign(100, 1.5f);
  const float* block = v.data();
  reserveLarge(v, 5000);
  resizeLarge(v, 4000);
  EXPECT_EQ(v.data(), block);
  EXPECT_EQ(v.capacity(), 5000u);
  EXPECT_EQ(v[99], 1.5f);
  EXPECT_EQ(v[100], 0.0f);
}

// Grown one element at a time, a buffer takes the capacities push_back gives it: the map's
// memory per voxel stays what it was.
TEST(LargeBuffersTest, GrowingOneAtATimeDoublesAsPushBackDoes) {
  std::vector<int> pushed, large;
  for (int i = 0; i < 100000; ++i) {
    pushed.push_back(i);
    reserveLarge(large, large.size() + 1);
    large.push_back(i);
    ASSERT_EQ(large.capacity(), pushed.capacity()) << "at " << i;
  }
  EXPECT_EQ(large, pushed);
}

// Elements are moved into the grown block, not copied: a buffer of owners keeps what they own.
TEST(LargeBuffersTest, ElementsAreMovedIntoTheGrownBlock) {
  std::vector<std::unique_ptr<int>> v;
  for (int i = 0; i < 10; ++i) v.push_back(std::make_unique<int>(i));
  const int* third = v[3].get();
  reserveLarge(v, kHugePageBytes);
  ASSERT_EQ(v.size(), 10u);
  EXPECT_EQ(v[3].get(), third);
  for (int i = 0; i < 10; ++i) EXPECT_EQ(*v[i], i);
}

// The advice is a hint on ranges of any size and alignment, before or after they are written:
// what is written afterwards reads back, and what was written before stays.
TEST(LargeBuffersTest, AdviceLeavesTheBytesAsWritten) {
  std::vector<std::uint8_t> bytes(2 * kHugePageBytes + 12345);
  for (std::size_t i = 0; i < bytes.size(); ++i) bytes[i] = static_cast<std::uint8_t>(i * 7);
  adviseHugePages(bytes.data() + 3, bytes.size() - 3);
  adviseHugePages(bytes.data(), 100);
  for (std::size_t i = 0; i < bytes.size(); ++i) ASSERT_EQ(bytes[i], static_cast<std::uint8_t>(i * 7)) << i;
  std::vector<double> fresh;
  fresh.reserve(kHugePageBytes);
  adviseHugePages(fresh.data(), fresh.capacity() * sizeof(double));
  fresh.assign(kHugePageBytes, 0.25);
  for (std::size_t i = 0; i < fresh.size(); i += 4099) ASSERT_EQ(fresh[i], 0.25) << i;
}

}  // namespace
}  // namespace terrain
