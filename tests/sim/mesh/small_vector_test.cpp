// SmallVector against std::vector: the same elements in the same order after every
// operation, inline and on the heap, through copies and moves.
#include "sim/mesh/small_vector.h"

#include <cstdint>
#include <random>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

namespace ld::mesh {
namespace {

using Small = SmallVector<std::uint32_t, 4>;

std::vector<std::uint32_t> asVector(const Small& s) { return {s.begin(), s.end()}; }

TEST(SmallVector, StaysInlineUpToItsRoomThenMovesToTheHeap) {
  Small s;
  EXPECT_TRUE(s.empty());
  EXPECT_EQ(s.capacity(), 4u);
  for (std::uint32_t i = 0; i < 4; ++i) s.push_back(i);
  EXPECT_FALSE(s.onHeap());
  s.push_back(4);
  EXPECT_TRUE(s.onHeap());
  EXPECT_EQ(s.capacity(), 8u);
  EXPECT_EQ(asVector(s), (std::vector<std::uint32_t>{0, 1, 2, 3, 4}));
  EXPECT_EQ(s.front(), 0u);
  EXPECT_EQ(s.back(), 4u);
}

TEST(SmallVector, PushBackOfItsOwnElementWhileGrowing) {
  Small s;
  for (std::uint32_t i = 0; i < 4; ++i) s.push_back(10 + i);
  s.push_back(s[1]);  // the element's storage moves during the push
  EXPECT_EQ(asVector(s), (std::vector<std::uint32_t>{10, 11, 12, 13, 11}));
}

TEST(SmallVector, CopiesAndMovesKeepTheElements) {
  for (std::uint32_t n : {0u, 3u, 4u, 9u}) {
    Small a;
    for (std::uint32_t i = 0; i < n; ++i) a.push_back(7 * i);
    const auto expect = asVector(a);
    Small copy(a);
    EXPECT_EQ(asVector(copy), expect) << n;
    copy.push_back(99);  // the copy owns its storage
    EXPECT_EQ(asVector(a), expect) << n;
    Small moved(std::move(copy));
    EXPECT_EQ(moved.size(), n + 1) << n;
    EXPECT_TRUE(copy.empty()) << n;  // NOLINT(bugprone-use-after-move): specified here
    Small assigned;
    for (std::uint32_t i = 0; i < 6; ++i) assigned.push_back(i);
    assigned = a;
    EXPECT_EQ(assigned, a) << n;
    assigned = std::move(moved);
    EXPECT_EQ(assigned.size(), n + 1) << n;
    EXPECT_EQ(assigned.back(), 99u) << n;
  }
}

TEST(SmallVector, EraseIfKeepsTheOthersInOrder) {
  Small s;
  for (std::uint32_t i = 0; i < 10; ++i) s.push_back(i);
  EXPECT_EQ(s.eraseIf([](std::uint32_t x) { return x % 3 == 0; }), 4u);
  EXPECT_EQ(asVector(s), (std::vector<std::uint32_t>{1, 2, 4, 5, 7, 8}));
}

// Random operations on both containers, compared after each.
TEST(SmallVector, FollowsStdVectorUnderRandomOperations) {
  std::mt19937 rng(2026);
  Small s;
  std::vector<std::uint32_t> v;
  for (int step = 0; step < 20000; ++step) {
    const auto op = rng() % 7;
    const auto x = static_cast<std::uint32_t>(rng() % 1000);
    switch (op) {
      case 0:
      case 1:
      case 2:
        s.push_back(x);
        v.push_back(x);
        break;
      case 3:
        if (!v.empty()) {
          s.pop_back();
          v.pop_back();
        }
        break;
      case 4: {
        const std::size_t n = rng() % 12;
        s.resize(n);
        v.resize(n);
        break;
      }
      case 5:
        s.eraseIf([&](std::uint32_t y) { return y % 5 == x % 5; });
        std::erase_if(v, [&](std::uint32_t y) { return y % 5 == x % 5; });
        break;
      default: {
        Small t(s);  // round trip through a copy and a move
        s = std::move(t);
        break;
      }
    }
    ASSERT_EQ(asVector(s), v) << "step " << step;
    ASSERT_GE(s.capacity(), s.size());
  }
}

}  // namespace
}  // namespace ld::mesh
