#include "models/shape/near_list.hpp"

#include <algorithm>

namespace swarmsim {

void NearLists::Slots::assign(std::size_t n, std::size_t capacity) {
  ids.assign(n * capacity, 0);
  len.assign(n, kNone);
  radius.assign(n, 0.0f);
  movedAt.assign(n, 0.0);
}

void NearLists::reset(std::size_t n, std::size_t capacity, float skin) {
  skin_ = skin;
  if (n == n_ && capacity == capacity_) return;
  n_ = n;
  capacity_ = capacity;
  last_.assign(n, capacity);
  next_.assign(n, capacity);
}

void NearLists::clear() {
  std::fill(last_.len.begin(), last_.len.end(), kNone);
  std::fill(next_.len.begin(), next_.len.end(), kNone);
}

const std::uint32_t* NearLists::keep(std::uint32_t from, std::uint32_t k, std::size_t& m) {
  m = last_.len[from];
  const std::uint32_t* old = last_.ids.data() + static_cast<std::size_t>(from) * capacity_;
  std::uint32_t* list = next_.ids.data() + static_cast<std::size_t>(k) * capacity_;
  std::copy(old, old + m, list);
  next_.len[k] = static_cast<std::uint32_t>(m);
  next_.radius[k] = last_.radius[from];
  next_.movedAt[k] = last_.movedAt[from];
  return list;
}

const std::uint32_t* NearLists::build(std::uint32_t k, float r, const UniformGrid& grid, const std::uint32_t* idOf,
                                      std::vector<std::uint32_t>& scratch, std::size_t& m) {
  rebuilt_.fetch_add(1, std::memory_order_relaxed);
  const float qx = grid.sortedX()[k], qy = grid.sortedY()[k], qz = grid.sortedZ()[k];
  scratch.clear();
  grid.forEachNeighbor(qx, qy, qz, r, [&](std::uint32_t j, float, float, float, float) {
    if (j != k) scratch.push_back(idOf[j]);
  });
  std::sort(scratch.begin(), scratch.end());
  m = scratch.size();
  if (m > capacity_) {
    next_.len[k] = kNone;
    return scratch.data();
  }
  std::uint32_t* list = next_.ids.data() + static_cast<std::size_t>(k) * capacity_;
  std::copy(scratch.begin(), scratch.end(), list);
  next_.len[k] = static_cast<std::uint32_t>(m);
  next_.radius[k] = r;
  next_.movedAt[k] = moved_;
  return list;
}

}  // namespace swarmsim
