//===- UnionIndexing.h - numbering of primitive-union instances -*- C++ -*-===//
//
// The instances of a primitive union are the tagged pairs (member, instance)
// of the paper's section 4.6.2. The runtime and the kernels agree to store
// such a pair as one integer: the prefix offset of the member plus the
// instance index, so member j's instances are numbered after those of members
// 0..j-1. Kernels decode it with the same prefix offsets.
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_RUNTIME_ASSEMBLY_UNIONINDEXING_H
#define YASPS_RUNTIME_ASSEMBLY_UNIONINDEXING_H

#include <cstddef>
#include <cstdint>
#include <vector>

namespace yasps::runtime {

/// A (member, instance) pair of a primitive union.
struct UnionInstance {
  std::size_t member;
  std::int64_t instance;

  bool operator==(const UnionInstance &other) const {
    return member == other.member && instance == other.instance;
  }
};

/// Encodes and decodes union instance indices for given member sizes.
class UnionIndexing {
public:
  /// `memberCounts[j]` is the instance count of the j-th member. Throws
  /// std::invalid_argument for an empty list or a negative count.
  explicit UnionIndexing(std::vector<std::int64_t> memberCounts);

  /// Total number of instances of the union.
  std::int64_t size() const { return offsets_.back(); }
  std::size_t numMembers() const { return offsets_.size() - 1; }

  /// Prefix offsets: member j's instances are [offsets()[j], offsets()[j+1]).
  const std::vector<std::int64_t> &offsets() const { return offsets_; }

  /// The union index of instance `instance` of member `member`. Throws
  /// std::out_of_range, naming the bounds, if either is out of range.
  std::int64_t encode(std::size_t member, std::int64_t instance) const;

  /// The (member, instance) pair of a union index. Throws std::out_of_range
  /// if `index` is not in [0, size()).
  UnionInstance decode(std::int64_t index) const;

  /// Changes one member's count (dynamic members) and renumbers.
  void setMemberCount(std::size_t member, std::int64_t count);

private:
  std::vector<std::int64_t> offsets_;
};

} // namespace yasps::runtime

#endif // YASPS_RUNTIME_ASSEMBLY_UNIONINDEXING_H
