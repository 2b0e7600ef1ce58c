// Turning a wrapping hardware counter into an axis position.
//
// The thermal gantry's position board (the paper's section 2.4) has an 8253 DOWN counter per
// axis: every encoder edge decrements it, whatever the direction, and a status register holds
// the direction of the motion. With an N-bit counter (modulus M = 2^N) read at instants k-1
// and k, the number of edges between the reads is
//
//     n = (C[k-1] - C[k]) mod M          (0 <= n < M; mod is the mathematical, non-negative one)
//
// and the signed displacement in counts is  d = dir ? -n : +n. This holds across the wrap:
// with C[k-1] = 5 and C[k] = 65534 (M = 65536) the counter passed 5, 4, ..., 0, 65535, 65534:
// n = (5 - 65534) mod 65536 = 7 edges.
//
// The paper's formula for that case (C[k] > C[k-1]) is
//     position = IP + | C[k-1] - (65535 - C[k]) |
// which gives |5 - 1| = 4 for the example: wrong by more than an off-by-one, since it
// mirrors C[k] instead of adding one modulus. `paper_wrap_delta()` keeps it for the record.
//
// Limits of this hardware, which the executor guards against:
//   * the displacement between two reads must stay below M / 2 edges (here 32768 counts,
//     815 mm at x4 decoding), far beyond what the axis can move in a servo period;
//   * edges of both directions between two reads are all counted with the latest direction,
//     so a reversal inside one period reads as up to a few counts of error. At 1 kHz and
//     near-zero speed at the reversal this is at most a count or two; it is the price of the
//     paper's hardware (a quadrature up/down counter does not have it);
//   * a jump no axis can make in one period is a fault (encoder glitch, or a counter read as
//     two bytes while it carries from the low byte into the high one, which errs by a
//     multiple of 256): `plausible()` tells, and the executor stops.
//
// Real time: every member is O(1), allocates nothing and never throws.
#pragma once

#include <cstdint>
#include <cstdlib>

namespace machplan::control {

// Signed counts moved between two reads of a `bits`-bit down counter with direction bit.
inline std::int64_t down_counter_delta(std::uint32_t previous, std::uint32_t current, bool direction_negative,
                                       int bits) {
  const std::uint64_t modulus = std::uint64_t{1} << bits;
  const std::uint64_t n = (static_cast<std::uint64_t>(previous) + modulus - current) & (modulus - 1);
  return direction_negative ? -static_cast<std::int64_t>(n) : static_cast<std::int64_t>(n);
}

// The paper's rule (section 4.4), reproduced only to show where it goes wrong; 16-bit.
inline std::int64_t paper_wrap_delta(std::uint32_t previous, std::uint32_t current, bool direction_negative) {
  const std::int64_t ic = previous, cc = current;
  const std::int64_t n = cc <= ic ? std::llabs(ic - cc) : std::llabs(ic - (65535 - cc));
  return direction_negative ? -n : n;
}

// Keeps the unwrapped position of one axis.
class CounterDecoder {
 public:
  // `mm_per_count`: travel per counted edge; `bits`: counter width (8 .. 32);
  // `max_counts_per_read`: the largest |displacement| accepted between two reads.
  void configure(double mm_per_count, int bits, std::int64_t max_counts_per_read) {
    mm_per_count_ = mm_per_count;
    bits_ = bits;
    max_counts_ = max_counts_per_read;
  }

  // Sets the reference: the counter shows `counter` while the axis is at `position_mm`.
  void reset(std::uint32_t counter, double position_mm) {
    last_ = counter;
    origin_mm_ = position_mm;
    counts_ = 0;
    moved_ = false;
  }

  enum class Verdict { ok, implausible_jump, byte_carry_misread };

  // Decodes one read. On `ok` the position advances; otherwise it is left unchanged (the last
  // known position is kept) and `last_jump_counts()` says how far the reading jumped.
  Verdict update(std::uint32_t counter, bool direction_negative) {
    const std::int64_t d = down_counter_delta(last_, counter, direction_negative, bits_);
    // The counter only counts down, so n edges really are n edges: a small move can never
    // show up as a count near the modulus. Anything beyond the axis's reach is a fault.
    const std::int64_t n = d < 0 ? -d : d;
    jump_ = d;
    if (n > max_counts_) {
      // The 8253 is read as two bytes; reading across a carry errs by whole multiples of 256.
      const std::int64_t r = n % 256;
      const bool byte_like = bits_ > 8 && (r <= max_counts_ || 256 - r <= max_counts_);
      return byte_like ? Verdict::byte_carry_misread : Verdict::implausible_jump;
    }
    counts_ += d;
    moved_ = moved_ || d != 0;
    last_ = counter;
    return Verdict::ok;
  }

  // The counter shows n = floor((x - x0) / q) edges from the reference x0, itself an edge (the
  // axis is referenced on one): the axis is somewhere in [x0 + n q, x0 + (n + 1) q). The
  // middle of that interval is returned, which errs by at most q/2. (The interval's lower edge
  // errs by q/2 on average, the same way on every axis: on a circle that bias alone is a
  // contour error of up to q / sqrt(2).) Until the first edge, the reference itself, where
  // the axis is known to stand.
  double position_mm() const {
    return moved_ ? origin_mm_ + (static_cast<double>(counts_) + 0.5) * mm_per_count_ : origin_mm_;
  }
  std::int64_t counts() const { return counts_; }
  std::int64_t last_jump_counts() const { return jump_; }
  double mm_per_count() const { return mm_per_count_; }

 private:
  double mm_per_count_ = 1.0;
  int bits_ = 16;
  std::int64_t max_counts_ = 1;
  std::uint32_t last_ = 0;
  double origin_mm_ = 0.0;
  std::int64_t counts_ = 0;
  bool moved_ = false;
  std::int64_t jump_ = 0;
};

}  // namespace machplan::control
