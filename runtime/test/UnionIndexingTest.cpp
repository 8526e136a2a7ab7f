//===- UnionIndexingTest.cpp - tests of union instance numbering ----------===//

#include "yasps/Runtime/Assembly/UnionIndexing.h"

#include <gtest/gtest.h>

#include <stdexcept>

using yasps::runtime::UnionIndexing;
using yasps::runtime::UnionInstance;

TEST(UnionIndexing, NumbersMembersOneAfterAnother) {
  UnionIndexing indexing({3, 2, 4});
  EXPECT_EQ(indexing.size(), 9);
  EXPECT_EQ(indexing.offsets(), (std::vector<std::int64_t>{0, 3, 5, 9}));
  EXPECT_EQ(indexing.encode(0, 2), 2);
  EXPECT_EQ(indexing.encode(1, 0), 3);
  EXPECT_EQ(indexing.encode(2, 3), 8);
}

TEST(UnionIndexing, DecodeInvertsEncode) {
  UnionIndexing indexing({5, 1, 7, 2});
  for (std::size_t member = 0; member < indexing.numMembers(); ++member) {
    std::int64_t count =
        indexing.offsets()[member + 1] - indexing.offsets()[member];
    for (std::int64_t i = 0; i < count; ++i)
      EXPECT_EQ(indexing.decode(indexing.encode(member, i)),
                (UnionInstance{member, i}));
  }
}

TEST(UnionIndexing, SkipsEmptyMembers) {
  UnionIndexing indexing({2, 0, 0, 3});
  EXPECT_EQ(indexing.decode(1), (UnionInstance{0, 1}));
  EXPECT_EQ(indexing.decode(2), (UnionInstance{3, 0}));
  EXPECT_THROW(indexing.encode(1, 0), std::out_of_range);
}

TEST(UnionIndexing, RejectsOutOfRange) {
  UnionIndexing indexing({2, 2});
  EXPECT_THROW(indexing.encode(2, 0), std::out_of_range);
  EXPECT_THROW(indexing.encode(0, 2), std::out_of_range);
  EXPECT_THROW(indexing.encode(0, -1), std::out_of_range);
  EXPECT_THROW(indexing.decode(4), std::out_of_range);
  EXPECT_THROW(indexing.decode(-1), std::out_of_range);
  EXPECT_THROW(UnionIndexing({}), std::invalid_argument);
  EXPECT_THROW(UnionIndexing({1, -1}), std::invalid_argument);
}

TEST(UnionIndexing, RenumbersWhenAMemberChangesSize) {
  UnionIndexing indexing({2, 3, 1});
  indexing.setMemberCount(1, 5);
  EXPECT_EQ(indexing.offsets(), (std::vector<std::int64_t>{0, 2, 7, 8}));
  EXPECT_EQ(indexing.decode(7), (UnionInstance{2, 0}));
  indexing.setMemberCount(0, 0);
  EXPECT_EQ(indexing.decode(0), (UnionInstance{1, 0}));
}
