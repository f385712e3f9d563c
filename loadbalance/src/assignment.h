// Best assignment (the Hungarian method, O(n^3)): used by rcb to give each
// new part the label of the current world it overlaps most.
#pragma once

#include <vector>

namespace soda::detail {

/// For a square matrix of weights (weight[row][column], n x n, any finite
/// values), the column of each row such that every column is used once and
/// the sum of weights is largest. Ties resolve deterministically (the same
/// matrix always gives the same answer). Pure function.
std::vector<int> max_weight_assignment(const std::vector<std::vector<double>>& weight);

}  // namespace soda::detail
