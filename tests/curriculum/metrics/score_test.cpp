#include "curriculum/metrics/score.h"

#include "tests/support/test_support.h"

namespace ld::curriculum {
namespace {

Metrics sample() {
  Metrics m;
  m.deviation.xy = 412.0;
  m.totalTimeS = 60.0;
  m.bandFraction = 0.8;
  m.contactBreaks = 3;
  m.pathBreaks = 1;
  m.contact.maxS = 1.25;
  return m;
}

TEST(Score, FlsFormNormalised) {
  ScoringSettings s;
  s.timeLimitS = 300.0;
  s.weights.deviationPerMm2 = 0.1;
  EXPECT_TRUE(test::near(score(sample(), s), 100.0 * (300 - 60 - 41.2) / 300, 1e-9));
  s.weights.uncutFraction = 100.0;  // 20 s for the 20% outside the band
  s.weights.contactBreak = 2.0;
  EXPECT_TRUE(test::near(penalty(sample(), s.weights), 41.2 + 20 + 6, 1e-9));
  s.weights.deviationPerMm2 = 10.0;  // penalty past the limit: score clamps to 0
  EXPECT_EQ(score(sample(), s), 0.0);
  s = ScoringSettings{};
  s.timeLimitS = 60.0;
  EXPECT_EQ(score(sample(), s), 0.0);
}

TEST(Score, ReadableReasons) {
  ScoringSettings s;
  s.timeLimitS = 300.0;
  Thresholds t;
  t.maxDeviationMm2 = 300.0;
  t.maxTimeS = 90.0;
  t.minBandFraction = 0.9;
  t.maxContactBreaks = 2;
  const Assessment a = assess(sample(), s, t);
  EXPECT_FALSE(a.passed);
  ASSERT_EQ(a.failures.size(), 3u);
  EXPECT_EQ(a.failures[0], "deviation 412 mm² over the 300 mm² limit");
  EXPECT_EQ(a.failures[1], "80% of the path cut within the band, under the 90% required");
  EXPECT_EQ(a.failures[2], "contact breaks 3 over the 2 limit");
  ASSERT_EQ(a.passes.size(), 1u);
  EXPECT_EQ(a.passes[0], "time 60 s within the 90 s limit");
  Metrics good = sample();
  good.deviation.xy = 120.0;
  good.bandFraction = 0.95;
  good.contactBreaks = 0;
  EXPECT_TRUE(assess(good, s, t).passed);
}

TEST(Proficiency, TwoConsecutivePasses) {
  EXPECT_FALSE(proficient({true, false, true, false}));
  EXPECT_TRUE(proficient({true, false, true, true}));
  EXPECT_EQ(proficiencyReachedAt({false, true, false, true, true, true}), 4);
  EXPECT_EQ(proficiencyReachedAt({true, true, true}, 3), 2);
  EXPECT_EQ(proficiencyReachedAt({}, 2), -1);
}

}  // namespace
}  // namespace ld::curriculum
