// The estimator registry (core/estimator_registry.h): the estimators the
// front ends list, the parameters they generate options and widgets from,
// and the generic settings that hold them (core/estimator.h).
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "core/estimator.h"
#include "core/estimator_registry.h"

using namespace vsl;

namespace {
const EstimatorParam* paramOf(const EstimatorInfo& e, const std::string& name) {
  for (const EstimatorParam& p : e.params)
    if (name == p.spec.name) return &p;
  return nullptr;
}
}  // namespace

// Both estimators are registered, brute force first (the default), each with
// its parameters declared once: MRCS's rows and clusters are the method's,
// its mix and spread our experiments. (Written so that a third estimator
// needs no change here: core/CMakeLists.txt's order after brute force is free.)
TEST(Estimators, RegistryListsBothWithTheirParameters) {
  const std::vector<EstimatorInfo>& all = estimators();
  ASSERT_GE(all.size(), 2u);
  EXPECT_EQ(all[0].name, "brute-force");
  EXPECT_EQ(all[0].name, EstimatorSettings::kDefaultName);
  ASSERT_TRUE(findEstimator("mrcs"));
  const EstimatorInfo& mrcs = *findEstimator("mrcs");
  size_t params = 0;
  for (const EstimatorInfo& e : all) {
    params += e.params.size();
    EXPECT_FALSE(e.help.empty()) << e.name;
    EXPECT_FALSE(e.label.empty()) << e.name;
    EXPECT_TRUE(e.create) << e.name;
    EXPECT_EQ(findEstimator(e.name), &e);
  }
  EXPECT_TRUE(all[0].params.empty()) << "brute force's parameters are the many-light settings'";
  EXPECT_TRUE(all[0].vplVariants);
  EXPECT_FALSE(all[0].wholeSetPerStep);
  EXPECT_FALSE(mrcs.vplVariants);
  EXPECT_TRUE(mrcs.wholeSetPerStep);
  struct Want {
    const char* name;
    const char* key;
    ParamKind kind;
    ParamTier tier;
    double defaultValue;
  };
  const Want want[] = {{"mrcs-rows", "mrcsRows", ParamKind::Int, ParamTier::Method, 300},
                       {"mrcs-clusters", "mrcsClusters", ParamKind::Int, ParamTier::Method, 900},
                       {"mrcs-mix", "mrcsMix", ParamKind::Real, ParamTier::Experimental, 0},
                       {"mrcs-spread", "mrcsSpread", ParamKind::Flag, ParamTier::Experimental, 0}};
  ASSERT_EQ(mrcs.params.size(), std::size(want));
  EXPECT_EQ(estimatorParams().all().size(), params) << "every registered estimator's parameters";
  for (size_t i = 0; i < std::size(want); ++i) {
    const EstimatorParam* p = paramOf(mrcs, want[i].name);
    ASSERT_TRUE(p) << want[i].name;
    EXPECT_STREQ(p->spec.key, want[i].key);
    EXPECT_EQ(p->spec.kind, want[i].kind) << want[i].name;
    EXPECT_EQ(p->spec.tier, want[i].tier) << want[i].name;
    EXPECT_EQ(p->defaultValue, want[i].defaultValue) << want[i].name;
    EXPECT_GT(std::string(p->spec.help).size(), 10u) << want[i].name;
    EXPECT_GT(std::string(p->spec.why).size(), 10u) << want[i].name;
    EXPECT_STREQ(mrcs.params[i].spec.name, want[i].name) << "in the plug-in's order";
    EXPECT_TRUE(estimatorParams().find(want[i].name)) << want[i].name;
    EXPECT_EQ(estimatorOwning(want[i].name), &mrcs);
  }
  EXPECT_EQ(paramOf(mrcs, "mrcs-rows")->spec.max, 100000);
  EXPECT_EQ(paramOf(mrcs, "mrcs-clusters")->spec.max, 1000000);
  EXPECT_EQ(paramOf(mrcs, "mrcs-mix")->spec.max, 1);
  EXPECT_EQ(estimatorOwning("mrcs"), &mrcs) << "the shorthand --mrcs";
  EXPECT_EQ(estimatorOwning("lights"), nullptr) << "a many-light parameter";
}

// An unknown name is refused with the nearest registered one, if any is near.
TEST(Estimators, UnknownNameSaysTheNearest) {
  Result<const EstimatorInfo*> e = lookupEstimator("mrc");
  ASSERT_FALSE(e);
  EXPECT_NE(e.error().find("unknown estimator 'mrc'"), std::string::npos) << e.error();
  EXPECT_NE(e.error().find("did you mean 'mrcs'?"), std::string::npos) << e.error();
  e = lookupEstimator("bruteforce");
  ASSERT_FALSE(e);
  EXPECT_NE(e.error().find("did you mean 'brute-force'?"), std::string::npos) << e.error();
  e = lookupEstimator("photon-mapping");
  ASSERT_FALSE(e);
  EXPECT_EQ(e.error().find("did you mean"), std::string::npos) << e.error();
  EXPECT_NE(e.error().find("one of brute-force, "), std::string::npos) << e.error();
  EXPECT_NE(e.error().find("mrcs"), std::string::npos) << e.error();
  EstimatorSettings s;
  s.name = "mrc";
  EXPECT_NE(s.validate().error().find("did you mean 'mrcs'?"), std::string::npos);
}

// The settings hold a name and values by parameter name: absent values are
// the defaults, only the chosen estimator's count, and the checks and the
// text are the plug-in's (MRCS keeps its shorthand and its messages).
TEST(Estimators, SettingsAreGeneric) {
  EstimatorSettings e;
  EXPECT_EQ(e.describe(), "brute-force");
  EXPECT_TRUE(e.validate());
  e.values["mrcs-rows"] = 0;  // another estimator's value: ignored
  EXPECT_TRUE(e.validate());
  EXPECT_TRUE(e.sameEstimate(EstimatorSettings{}));
  ManyLightSettings roulette;
  roulette.pairRoulette = 1;
  EXPECT_TRUE(e.validateWith(roulette)) << "brute force plays the pair roulette";

  e = EstimatorSettings{};
  e.name = "mrcs";
  EXPECT_EQ(e.value("mrcs-rows"), 300);
  EXPECT_EQ(e.value("mrcs-clusters"), 900);
  EXPECT_EQ(e.describe(), "mrcs --mrcs 300,900,0");
  EXPECT_FALSE(e.sameEstimate(EstimatorSettings{}));
  EstimatorSettings same = e;
  same.values["mrcs-rows"] = 300;  // the default, given
  EXPECT_TRUE(e.sameEstimate(same));
  same.values["mrcs-spread"] = 1;
  EXPECT_FALSE(e.sameEstimate(same));
  EXPECT_EQ(same.describe(), "mrcs --mrcs 300,900,0 --mrcs-spread");
  same.progressiveRadius = true;
  EXPECT_EQ(same.describe(), "mrcs --mrcs 300,900,0 --mrcs-spread --progressive-radius 0.7");
  Result<void> with = e.validateWith(roulette);
  ASSERT_FALSE(with);
  EXPECT_EQ(with.error(), "pair-roulette: brute force only, not with MRCS");
  e.values["mrcs-rows"] = 0;
  EXPECT_NE(e.validate().error().find("mrcs rows: must be in [1,100000]"), std::string::npos) << e.validate().error();
  e.values["mrcs-rows"] = 10;
  e.values["mrcs-mix"] = 2;
  EXPECT_FALSE(e.validate());

  // The shorthand sets the name and three values; anything else is refused.
  const EstimatorInfo& mrcs = *findEstimator("mrcs");
  EstimatorSettings s;
  ASSERT_TRUE(mrcs.parseShorthand("10,20,0.5", s));
  EXPECT_EQ(s.name, "mrcs");
  EXPECT_EQ(s.value("mrcs-rows"), 10);
  EXPECT_EQ(s.value("mrcs-clusters"), 20);
  EXPECT_EQ(s.value("mrcs-mix"), 0.5);
  // The shorthand's MIX has the bits --mrcs-mix gives it (a float's).
  const ParamSpec& mix = paramOf(mrcs, "mrcs-mix")->spec;
  ASSERT_TRUE(mrcs.parseShorthand("10,20,0.123456789", s));
  EXPECT_EQ(s.value("mrcs-mix"), parseParamValue(mix, "0.123456789").value());
  for (const char* bad : {"10", "10,20x", "10,20,", "x,20", ""}) {
    Result<void> r = mrcs.parseShorthand(bad, s);
    ASSERT_FALSE(r) << bad;
    EXPECT_NE(r.error().find("--mrcs must be ROWS,CLUSTERS"), std::string::npos) << r.error();
  }

  // MRCS's memory beyond brute force's grows with its rows, which are capped
  // at the pixels.
  EXPECT_EQ(estimatorMemory(EstimatorSettings{}, 10000).bytesPerLight, 0u);
  EstimatorSettings rows = s;
  const uint64_t few = estimatorMemory(rows, 10000).bytesPerLight;
  rows.values["mrcs-rows"] = 1000;
  EXPECT_EQ(estimatorMemory(rows, 10000).bytesPerLight, few + 2 * 990 * sizeof(float));
  EXPECT_EQ(estimatorMemory(rows, 100).bytesPerLight, few + 2 * 90 * sizeof(float)) << "a row per pixel at most";
}
