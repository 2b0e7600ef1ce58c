// Reads a fuzzer's input as a stream of small integers; past the end every read gives 0, so a
// target never reads outside the input and every length of input is a valid case.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>

namespace machplan::fuzz {

struct Bytes {
  const uint8_t* p;
  size_t n;
  int16_t i16() {
    int16_t v = 0;
    if (n >= 2) {
      std::memcpy(&v, p, 2);
      p += 2, n -= 2;
    }
    return v;
  }
  uint8_t u8() {
    if (n == 0) return 0;
    --n;
    return *p++;
  }
};

}  // namespace machplan::fuzz
