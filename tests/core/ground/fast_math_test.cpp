#include "core/ground/fast_math.hpp"
#include "core/ground/peak_histogram.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

namespace terrain::ground {
namespace {

// e^-x against the library's in double: within 2e-12 relative over the heights a pair weight sees
// (0-50 m, every 2^-12 m, and random floats), and at its ends.
TEST(FastMathTest, ExpNegativeAgreesWithExp) {
  double worst = 0;
  for (int i = 0; i <= 50 * 4096; ++i) {
    const float x = static_cast<float>(i) / 4096.0f;
    worst = std::max(worst, std::abs(expNegative(x) / std::exp(-static_cast<double>(x)) - 1));
  }
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> any(0.0f, 700.0f);
  for (int i = 0; i < 100000; ++i) {
    const float x = any(rng);
    worst = std::max(worst, std::abs(expNegative(x) / std::exp(-static_cast<double>(x)) - 1));
  }
  EXPECT_LT(worst, 2e-12);
  EXPECT_EQ(expNegative(0.0f), 1.0);
  EXPECT_GE(expNegative(1e30f), 0.0);  // clamped at 700: far below the least float
  EXPECT_LT(expNegative(1e30f), 1e-300);
  EXPECT_TRUE(std::isnan(expNegative(std::numeric_limits<float>::quiet_NaN())));
}

TEST(FastMathTest, FloorDivisionOfNegativeIndices) {
  for (int b : {1, 2, 3, 30, 64}) {
    for (int a = -200; a <= 200; ++a) {
      const int q = static_cast<int>(std::floor(static_cast<double>(a) / b));
      EXPECT_EQ(floorDiv(a, b), q) << a << " / " << b;
      EXPECT_EQ(floorMod(a, b), a - q * b) << a << " mod " << b;
      EXPECT_GE(floorMod(a, b), 0);
      EXPECT_LT(floorMod(a, b), b);
    }
  }
}

// the multiply and shift gives floor((a - base) / k) over the whole span its comment promises
TEST(FastMathTest, OffsetDividerIsFloorDivision) {
  std::mt19937 rng(3);
  for (int k : {1, 2, 3, 5, 7, 16, 30, 31, 33, 100, 1000}) {
    const int base = -(1 << 20);
    const OffsetDivider divide(base, k);
    std::uniform_int_distribution<int> in(base, base + (1 << 23) - 1);
    for (int i = 0; i < 20000; ++i) {
      const int a = in(rng);
      ASSERT_EQ(divide(a), (a - base) / k) << a << " k " << k;
    }
    for (int a : {base, base + k - 1, base + k, base + (1 << 23) - 1}) EXPECT_EQ(divide(a), (a - base) / k);
  }
}

// The peak is the mean of the heights in the fullest bin and its two neighbours; of equal peaks,
// the lowest (ground lies under objects).
TEST(FastMathTest, PeakHistogramRefinesTheFullestBin) {
  PeakHistogram h;
  h.reset(0.0, 10.0, 0.1);
  for (double z : {1.02, 1.04, 1.06, 1.13, 0.95, 5.01, 5.02, 5.03, 5.04, 9.99}) h.add(z);
  EXPECT_EQ(h.total(), 10);
  // fullest bin [5.0, 5.1) with 4; its neighbours are empty
  EXPECT_NEAR(h.peak(), (5.01 + 5.02 + 5.03 + 5.04) / 4, 1e-12);
  h.reset(0.0, 10.0, 0.1);
  for (double z : {2.01, 2.02, 7.01, 7.02}) h.add(z);
  EXPECT_NEAR(h.peak(), 2.015, 1e-12);
  h.reset(0.0, 1.0, 0.1);
  EXPECT_TRUE(std::isnan(h.peak()));
}

}  // namespace
}  // namespace terrain::ground
