// Which closed contours lie inside which: the nesting of a sheet's cuts or a drawing's
// contours (parts, their holes, parts in the holes, ...).
//
// A contour's holders are the other contours whose region (non-zero winding) holds its first
// vertex and whose enclosed area |signed_area| is larger; its parent is the smallest holder
// and its depth the number of holders: 0 for the outline of a part, 1 for a hole, 2 for a
// part inside a hole, and so on. For contours that neither cross nor touch this is the usual
// nesting tree (every holder encloses the whole contour, holders are nested in one another,
// so depth = parent's depth + 1); contours that cross get an answer but no guarantee.
//
// Work: one SpanIndex over every span (O(n log n) for n spans), then one ray query per
// contour, which looks only at the spans whose boxes meet the ray from the vertex towards +x:
// a sheet of parts laid out in rows costs about O(n sqrt(n)) in all, never the O(n^2) of
// testing every pair. Memory O(n).
//
// Thread safety: a pure function.
#pragma once

#include <cstddef>
#include <utility>
#include <vector>

#include "engine/geometry/contour.h"

namespace machplan {

struct Nesting {
  std::vector<int> parent;                 // index of the smallest holder, -1 at top level
  std::vector<int> depth;                  // number of holders
  std::vector<std::vector<int>> children;  // contours whose parent this is, ascending
};

// Empty contours hold nothing and have no holders. `crossing` lists pairs (i, j), either order,
// known to cross or touch (a drawing's overlapping outlines): neither holds the other, so that
// a contour is nested only in contours it lies wholly inside.
Nesting nest_contours(const std::vector<Contour>& contours,
                      const std::vector<std::pair<std::size_t, std::size_t>>& crossing = {});

}  // namespace machplan
