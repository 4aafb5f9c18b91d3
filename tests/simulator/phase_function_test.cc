// Phase functions (simulator/phase_function.h) against closed forms and an independent quadrature.
#include "simulator/phase_function.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "core/error.h"
#include "tests/support/test_support.h"

namespace turbid {
namespace {

constexpr double kPi = 3.14159265358979323846;

PhaseFunction Make(const std::string& model, double bb = 0.0183, double g = 0.924) {
  PhaseFunctionOptions o;
  o.model = model;
  o.backscatter_ratio = bb;
  o.g = g;
  return PhaseFunction(o);
}

// 2 pi integral_lo^hi p(t) sin t dt by composite Simpson in ln t (independent of the class's own
// trapezoid grid: another rule, another spacing, another lower end).
double Integrate(const PhaseFunction& p, double lo, double hi, int n = 20000) {
  const double a = std::log(lo), b = std::log(hi), h = (b - a) / n;
  double sum = 0;
  for (int i = 0; i <= n; ++i) {
    const double t = std::exp(a + i * h);
    const double f = 2 * kPi * p(t) * std::sin(t) * t;
    sum += f * (i == 0 || i == n ? 1 : (i % 2 ? 4 : 2));
  }
  return sum * h / 3;
}

TEST(PhaseFunction, FournierForandBackscatterFormulaGivesPetzoldValue) {
  // Mobley et al. (2002): n = 1.10, mu = 3.5835 is the FF member with Petzold's b_b/b 0.0183.
  EXPECT_NEAR(FournierForandBackscatterRatio(1.10, 3.5835), 0.0183, 1e-4);
  const PhaseFunction p = Make("fournier_forand");
  EXPECT_NEAR(p.FournierForandMu(), 3.5835, 2e-3);
}

TEST(PhaseFunction, FournierForandIsNormalisedAndHitsItsBackscatterRatio) {
  for (double bb : {0.005, 0.0183, 0.04}) {
    const PhaseFunction p = Make("fournier_forand", bb);
    // The forward peak: p ~ t^(mu - 5), so the light within t0 is 2 pi p(t0) t0^2 / (mu - 3)
    // (closed form; large for mu near 3 where the peak is sharpest; p is held at 1e-6 rad below).
    const double t0 = 1e-6, tail = 2 * kPi * p(t0) * t0 * t0 / (p.FournierForandMu() - 3);
    EXPECT_NEAR(Integrate(p, t0, kPi) + tail, 1.0, 2e-4) << bb;
    EXPECT_NEAR(Integrate(p, kPi / 2, kPi), bb, 1e-5) << bb;
    EXPECT_NEAR(p.BackscatterRatio(), bb, 1e-5) << bb;
    EXPECT_GT(p.MeanCosine(), 0.85) << bb;  // strongly forward
  }
}

TEST(PhaseFunction, HenyeyGreensteinMatchesClosedForms) {
  for (double g : {-0.3, 0.0, 0.5, 0.924}) {
    const PhaseFunction p = Make("henyey_greenstein", 0.0183, g);
    const double bb =
        g == 0 ? 0.5 : (1 - g * g) / (2 * g) * (1 / std::sqrt(1 + g * g) - 1 / (1 + g));
    EXPECT_NEAR(p.BackscatterRatio(), bb, 1e-6) << g;
    EXPECT_NEAR(p.MeanCosine(), g, 1e-6) << g;
    EXPECT_NEAR(Integrate(p, 1e-9, kPi), 1.0, 1e-6) << g;
    // F(t) = (1 - g^2) / (2g) (1/(1 - g) - 1/sqrt(1 + g^2 - 2 g cos t)).
    if (g != 0) {
      const double t = 0.3;
      const double f =
          (1 - g * g) / (2 * g) * (1 / (1 - g) - 1 / std::sqrt(1 + g * g - 2 * g * std::cos(t)));
      EXPECT_NEAR(p.FractionWithin(t), f, 1e-6) << g;
    }
  }
}

TEST(PhaseFunction, IsotropicFractionAndMeanSquareAngle) {
  const PhaseFunction p = Make("isotropic");
  for (double t : {0.01, 0.5, 1.0, 2.0, 3.0}) {
    EXPECT_NEAR(p.FractionWithin(t), (1 - std::cos(t)) / 2, 1e-7) << t;
  }
  // integral_0^pi t^2 sin t dt = pi^2 - 4, over integral sin t = 2.
  EXPECT_NEAR(p.MeanSquareAngle(kPi), (kPi * kPi - 4) / 2, 1e-6);
  // Within a small cone, sin t ~ t: <t^2> = t_max^2 / 2.
  EXPECT_NEAR(p.MeanSquareAngle(0.01) / (0.01 * 0.01 / 2), 1.0, 1e-4);
  EXPECT_NEAR(p.BackscatterRatio(), 0.5, 1e-9);
}

TEST(PhaseFunction, TabulatedReproducesTheFunctionItWasSampledFrom) {
  testing::TempDir dir;
  const PhaseFunction hg = Make("henyey_greenstein", 0.0183, 0.8);
  std::string csv = "angle_deg,p_per_sr\n";
  for (double deg = 0.1; deg < 180; deg *= 1.05)
    csv += std::to_string(deg) + "," + std::to_string(hg(deg * kPi / 180)) + "\n";
  csv += "180," + std::to_string(hg(kPi)) + "\n";
  PhaseFunctionOptions o;
  o.model = "tabulated";
  o.file = dir.Write("hg.csv", csv);
  const PhaseFunction tab(o);
  EXPECT_NEAR(tab.NormalisationFactor(), 1.0, 2e-3);
  EXPECT_NEAR(tab.BackscatterRatio(), hg.BackscatterRatio(), 2e-4);
  EXPECT_NEAR(tab.MeanCosine(), 0.8, 2e-3);
  for (double t : {0.01, 0.2, 1.0, 2.5}) EXPECT_NEAR(tab(t) / hg(t), 1.0, 5e-3) << t;
}

TEST(PhaseFunction, PetzoldAverageParticleTable) {
  TURBID_REQUIRE_DATA(data);
  PhaseFunctionOptions o;
  o.model = "tabulated";
  o.file = data + "/jerlov_iop/petzold_average_particle_phase_function_mobley1993.csv";
  const PhaseFunction p(o);
  // shared/data/jerlov_iop/SOURCE.md: the table integrates to 0.993-1.002, b_b/b = 0.01826.
  EXPECT_NEAR(p.NormalisationFactor(), 1.0, 0.01);
  EXPECT_NEAR(p.BackscatterRatio(), 0.0183, 4e-4);
  // The FF member with the same b_b/b is its analytic stand-in: the fraction within 10 deg
  // agrees to 0.05 (measured 0.668 vs 0.712).
  const PhaseFunction ff = Make("fournier_forand");
  EXPECT_NEAR(p.FractionWithin(10 * kPi / 180), ff.FractionWithin(10 * kPi / 180), 0.05);
}

TEST(PhaseFunction, BadOptionsAndTablesAreOneLineErrors) {
  EXPECT_THROW(Make("mie"), Error);
  EXPECT_THROW(Make("fournier_forand", 0.5), Error);
  EXPECT_THROW(Make("henyey_greenstein", 0.0183, 1.0), Error);
  testing::TempDir dir;
  PhaseFunctionOptions o;
  o.model = "tabulated";
  EXPECT_THROW(PhaseFunction{o}, Error);  // no file
  o.file = dir.Write("bad.csv", "angle,p\n1,2\n0.5,3\n");
  try {
    PhaseFunction{o};
    FAIL() << "decreasing angles accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("line 3"), std::string::npos) << e.what();
  }
  o.file = dir.Write("nan.csv", "angle,p\n1,nan\n2,3\n");
  EXPECT_THROW(PhaseFunction{o}, Error);
  o.file = dir.path() + "/missing.csv";
  EXPECT_THROW(PhaseFunction{o}, Error);
}

TEST(PhaseFunction, FieldTableReadsAndWritesTheOptions) {
  PhaseFunctionOptions o;
  PhaseFunctionFields().Read(nlohmann::json{{"model", "henyey_greenstein"}, {"g", 0.8}}, &o, "test",
                             "water.phase", "phase function");
  EXPECT_EQ(o.model, "henyey_greenstein");
  EXPECT_DOUBLE_EQ(o.g, 0.8);
  EXPECT_EQ(PhaseFunctionFields().ToJson(o)["g"], 0.8);
  EXPECT_THROW(PhaseFunctionFields().Read(nlohmann::json{{"gg", 0.8}}, &o, "test", "water.phase",
                                          "phase function"),
               Error);
}

}  // namespace
}  // namespace turbid
