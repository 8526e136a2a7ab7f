//===- UnionIndexing.cpp - numbering of primitive-union instances ---------===//

#include "yasps/Runtime/Assembly/UnionIndexing.h"

#include <algorithm>
#include <stdexcept>
#include <string>

using namespace yasps::runtime;

static void checkCount(std::size_t member, std::int64_t count) {
  if (count < 0)
    throw std::invalid_argument("union member " + std::to_string(member) +
                                " has a negative instance count (" +
                                std::to_string(count) + ")");
}

UnionIndexing::UnionIndexing(std::vector<std::int64_t> memberCounts) {
  if (memberCounts.empty())
    throw std::invalid_argument("a primitive union needs at least one member");
  offsets_.reserve(memberCounts.size() + 1);
  offsets_.push_back(0);
  for (std::size_t j = 0; j < memberCounts.size(); ++j) {
    checkCount(j, memberCounts[j]);
    offsets_.push_back(offsets_.back() + memberCounts[j]);
  }
}

std::int64_t UnionIndexing::encode(std::size_t member,
                                   std::int64_t instance) const {
  if (member >= numMembers())
    throw std::out_of_range("union member " + std::to_string(member) +
                            " out of range: the union has " +
                            std::to_string(numMembers()) + " members");
  std::int64_t count = offsets_[member + 1] - offsets_[member];
  if (instance < 0 || instance >= count)
    throw std::out_of_range("instance " + std::to_string(instance) +
                            " out of range for union member " +
                            std::to_string(member) + " with " +
                            std::to_string(count) + " instances");
  return offsets_[member] + instance;
}

UnionInstance UnionIndexing::decode(std::int64_t index) const {
  if (index < 0 || index >= size())
    throw std::out_of_range("union index " + std::to_string(index) +
                            " out of range: the union has " +
                            std::to_string(size()) + " instances");
  // The member is the last one whose offset is <= index; empty members share
  // their offset with the next one, and upper_bound skips past them.
  auto it = std::upper_bound(offsets_.begin(), offsets_.end(), index);
  std::size_t member = static_cast<std::size_t>(it - offsets_.begin()) - 1;
  return {member, index - offsets_[member]};
}

void UnionIndexing::setMemberCount(std::size_t member, std::int64_t count) {
  if (member >= numMembers())
    throw std::out_of_range("union member " + std::to_string(member) +
                            " out of range: the union has " +
                            std::to_string(numMembers()) + " members");
  checkCount(member, count);
  std::int64_t delta = count - (offsets_[member + 1] - offsets_[member]);
  for (std::size_t j = member + 1; j < offsets_.size(); ++j)
    offsets_[j] += delta;
}
