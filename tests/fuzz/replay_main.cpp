// Deterministic stand-in for libFuzzer when the compiler is not clang: runs every seed in the
// corpus folder, then a fixed number of mutations of each (bit flips, byte changes, truncation,
// duplication, splices with another seed), from a fixed seed so that a failure reproduces.
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size);

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s CORPUS_DIR\n", argv[0]);
    return 2;
  }
  std::vector<std::string> seeds;
  for (const auto& entry : std::filesystem::directory_iterator(argv[1])) {
    std::ifstream in(entry.path(), std::ios::binary);
    seeds.emplace_back(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  if (seeds.empty()) {
    std::fprintf(stderr, "%s: no seeds\n", argv[1]);
    return 2;
  }
  std::mt19937_64 rng(20261122);
  auto run = [](const std::string& s) {
    LLVMFuzzerTestOneInput(reinterpret_cast<const uint8_t*>(s.data()), s.size());
  };
  const char* tokens[] = {"G", "X", "-", ".", "(", ")", ";", "\n", "1e400", "R", "I", "#", "[", "0", "9"};
  std::size_t runs = 0;
  for (const auto& seed : seeds) {
    run(seed);
    for (int k = 0; k < 2000; ++k) {
      std::string m = seed;
      const int edits = 1 + static_cast<int>(rng() % 4);
      for (int e = 0; e < edits; ++e) {
        const std::size_t pos = m.empty() ? 0 : rng() % m.size();
        switch (rng() % 6) {
          case 0: if (!m.empty()) m[pos] = static_cast<char>(m[pos] ^ (1u << (rng() % 8))); break;
          case 1: if (!m.empty()) m[pos] = static_cast<char>(rng() % 256); break;
          case 2: m.resize(pos); break;
          case 3: m.insert(pos, tokens[rng() % std::size(tokens)]); break;
          case 4: m.insert(pos, m.substr(pos, rng() % 64)); break;
          case 5: {
            const auto& other = seeds[rng() % seeds.size()];
            m = m.substr(0, pos) + other.substr(other.empty() ? 0 : rng() % other.size());
            break;
          }
        }
      }
      run(m);
      ++runs;
    }
  }
  std::printf("replayed %zu seeds and %zu mutations without a crash\n", seeds.size(), runs);
  return 0;
}
