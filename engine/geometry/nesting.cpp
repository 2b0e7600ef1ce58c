#include "engine/geometry/nesting.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <utility>

#include "engine/geometry/span_index.h"

namespace machplan {

Nesting nest_contours(const std::vector<Contour>& contours,
                      const std::vector<std::pair<std::size_t, std::size_t>>& crossing) {
  std::vector<std::pair<std::size_t, std::size_t>> apart;
  for (const auto& [a, b] : crossing) apart.emplace_back(std::min(a, b), std::max(a, b));
  std::sort(apart.begin(), apart.end());
  const auto crosses = [&](std::size_t a, std::size_t b) {
    return std::binary_search(apart.begin(), apart.end(), std::make_pair(std::min(a, b), std::max(a, b)));
  };
  const std::size_t n = contours.size();
  Nesting out;
  out.parent.assign(n, -1);
  out.depth.assign(n, 0);
  out.children.resize(n);
  std::vector<Contour> indexed;
  std::vector<std::size_t> source;  // indexed contour -> position in `contours`
  std::vector<double> area(n, 0.0);
  for (std::size_t i = 0; i < n; ++i) {
    if (contours[i].empty()) continue;
    area[i] = std::abs(signed_area(contours[i]));
    indexed.push_back(contours[i]);
    source.push_back(i);
  }
  if (indexed.empty()) return out;
  const SpanIndex index(indexed);
  std::vector<std::pair<std::uint32_t, int>> held;
  for (std::size_t i = 0; i < n; ++i) {
    if (contours[i].empty()) continue;
    index.windings(contours[i].vertices().front(), held);
    for (const auto& [k, w] : held) {
      const std::size_t j = source[k];
      if (j == i || !(area[j] > area[i]) || (!apart.empty() && crosses(i, j))) continue;
      ++out.depth[i];
      if (out.parent[i] < 0 || area[j] < area[static_cast<std::size_t>(out.parent[i])]) out.parent[i] = static_cast<int>(j);
    }
  }
  for (std::size_t i = 0; i < n; ++i)
    if (out.parent[i] >= 0) out.children[static_cast<std::size_t>(out.parent[i])].push_back(static_cast<int>(i));
  return out;
}

}  // namespace machplan
