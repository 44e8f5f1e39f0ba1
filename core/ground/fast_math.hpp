#pragma once
// The ground segmentation's arithmetic kernels, each exact where it stands in for the standard
// operation: e^-x for the pair weights, floor division and modulo of grid indices, and division by
// a tile's fixed size as a multiply and a shift.

#include <cstdint>
#include <cstring>

namespace terrain::ground {

// 2^(j/32) for j = 0 .. 31, each the double nearest it
inline constexpr double kExp2Fraction[32] = {
    0x1.0000000000000p+0, 0x1.059b0d3158574p+0, 0x1.0b5586cf9890fp+0, 0x1.11301d0125b51p+0, 0x1.172b83c7d517bp+0,
    0x1.1d4873168b9aap+0, 0x1.2387a6e756238p+0, 0x1.29e9df51fdee1p+0, 0x1.306fe0a31b715p+0, 0x1.371a7373aa9cbp+0,
    0x1.3dea64c123422p+0, 0x1.44e086061892dp+0, 0x1.4bfdad5362a27p+0, 0x1.5342b569d4f82p+0, 0x1.5ab07dd485429p+0,
    0x1.6247eb03a5585p+0, 0x1.6a09e667f3bcdp+0, 0x1.71f75e8ec5f74p+0, 0x1.7a11473eb0187p+0, 0x1.82589994cce13p+0,
    0x1.8ace5422aa0dbp+0, 0x1.93737b0cdc5e5p+0, 0x1.9c49182a3f090p+0, 0x1.a5503b23e255dp+0, 0x1.ae89f995ad3adp+0,
    0x1.b7f76f2fb5e47p+0, 0x1.c199bdd85529cp+0, 0x1.cb720dcef9069p+0, 0x1.d5818dcfba487p+0, 0x1.dfc97337b9b5fp+0,
    0x1.ea4afa2a490dap+0, 0x1.f50765b6e4540p+0,
};

// e^-x for x >= 0 (NaN for NaN), in double. -x / ln 2 = (32 e + j + r) / 32 with whole e and j in
// 0 .. 31 and |r| <= 1/2, and e^-x = 2^e 2^(j/32) 2^(r/32): the first a shift of the exponent, the
// second from the table, the third from its Taylor polynomial of degree 4 (relative error below
// 1.3e-12), so that e^-x rounded to float is correctly rounded but for about one x in a few
// million (then one unit in the last place off). Branch-free and inline: 1.8 M voxels weigh three
// pairs each.
inline double expNegative(float x) {
  double v = x;
  v = v > 700.0 ? 700.0 : v;  // e^-700 is far below the least float; keeps e within the double's exponent range
  const double z = v * -0x1.71547652b82fep+5;  // -x * 32 / ln 2
  // z rounded to a whole number k by adding 1.5 * 2^52: k is then the low bits of the sum's
  // mantissa (two's complement), and the sum less 1.5 * 2^52 is k as a double
  constexpr double kRound = 0x1.8p52;
  const double shifted = z + kRound;
  std::uint64_t bits;
  std::memcpy(&bits, &shifted, sizeof bits);
  const double r = z - (shifted - kRound);
  std::uint64_t scale;
  std::memcpy(&scale, &kExp2Fraction[bits & 31], sizeof scale);
  scale += (bits >> 5) << 52;  // adds e to the exponent (wrapping in two's complement for e < 0)
  double s;
  std::memcpy(&s, &scale, sizeof s);
  // the polynomial by Estrin's scheme: two short chains of operations instead of one long one
  const double r2 = r * r;
  const double p = (1.0 + r * 0x1.62e42fefa39efp-6) +
                   r2 * ((0x1.ebfbdff82c58fp-13 + r * 0x1.c6b08d704a0c0p-20) + r2 * 0x1.3b2ab6fba4e77p-27);
  return s * p;
}

// floor(a / b) and the matching a mod b (in [0, b)) for b > 0
inline int floorDiv(int a, int b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }
inline int floorMod(int a, int b) { return a - floorDiv(a, b) * b; }

// floor((a - base) / k) for a fixed k >= 1 and a in [base, base + 2^23): a multiply and a shift
// in place of a division. With 2^l >= k and m = ceil(2^(23 + l) / k), (n m) >> (23 + l) is
// floor(n / k) for every 0 <= n < 2^23 (the rounding up of m adds less than 2^-l <= 1/k to n / k).
// A map's voxel indices span less than 2^21 (VoxelMap keeps them within +-2^20).
class OffsetDivider {
 public:
  OffsetDivider() = default;
  OffsetDivider(int base, int k) : base_(base) {
    int l = 0;
    while ((std::uint64_t{1} << l) < static_cast<std::uint64_t>(k)) ++l;
    shift_ = 23 + l;
    mul_ = ((std::uint64_t{1} << shift_) + static_cast<std::uint64_t>(k) - 1) / static_cast<std::uint64_t>(k);
  }
  int operator()(int a) const {
    return static_cast<int>((static_cast<std::uint64_t>(static_cast<std::uint32_t>(a - base_)) * mul_) >> shift_);
  }

 private:
  int base_ = 0, shift_ = 0;
  std::uint64_t mul_ = 0;
};

}  // namespace terrain::ground
