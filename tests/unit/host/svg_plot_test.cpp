// The torque plot as users read it: a legend, labelled axes with round time
// ticks, the measurement drawn over the prediction, and each log's part
// named as fit or validation.
#include "host_id/svg_plot.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

namespace host_id {
namespace {

Prediction synthetic(const std::string& name, const std::string& role) {
  Prediction p;
  p.log = name;
  p.role = role;
  for (int k = 0; k <= 12000; ++k) {
    const double t = 0.5 + k * 1e-3;  // 0.5 s to 12.5 s
    p.t_s.push_back(t);
    for (unsigned j = 0; j < 3; ++j) {
      p.measured_Nm[j].push_back(std::sin(t + j) + 0.01 * std::sin(40 * t));
      p.predicted_Nm[j].push_back(std::sin(t + j));
      p.velocity_rad_s[j].push_back(std::cos(t + j));
    }
  }
  return p;
}

std::size_t count(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (auto at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

TEST(SvgPlotTest, HasALegendTimeTicksRolesAndTheMeasurementOnTop) {
  const std::string svg = svg_torque_plot(
      {synthetic("path1.csv", "fit"), synthetic("path2.csv", "validation")}, "host_id fit");
  for (const char* label : {">measured<", ">predicted<", ">residual = measured - predicted<"}) {
    EXPECT_EQ(count(svg, label), 1u) << label;
  }
  EXPECT_NE(svg.find("path1.csv (fit: the log the parameters come from)"), std::string::npos);
  EXPECT_NE(svg.find("path2.csv (validation: held out of the fit)"), std::string::npos);
  // 12 s of data: ticks every 2 s from 2 to 12, under each residual panel
  // (3 joints x 2 logs), and the axis named.
  for (const char* tick : {">2</text>", ">4</text>", ">12</text>"}) {
    EXPECT_EQ(count(svg, tick), 6u) << tick;
  }
  EXPECT_EQ(count(svg, ">time [s]</text>"), 6u);
  EXPECT_EQ(count(svg, ">resid. [N m]</text>"), 6u);
  // In each torque panel the prediction comes first (underneath), the
  // measurement after it (drawn on top).
  const auto predicted = svg.find("stroke=\"#f5a55c\" stroke-width=\"3\"");
  const auto measured = svg.find("stroke=\"#1f4e9c\" stroke-width=\"1\"");
  ASSERT_NE(predicted, std::string::npos);
  ASSERT_NE(measured, std::string::npos);
  EXPECT_LT(predicted, measured);
  // Every element that opens is closed or self-closing: the file parses.
  EXPECT_EQ(count(svg, "<svg"), 1u);
  EXPECT_EQ(count(svg, "</svg>"), 1u);
  EXPECT_EQ(count(svg, "<text"), count(svg, "</text>"));
}

TEST(SvgPlotTest, ValidateAndPredictPlotsNameNoRole) {
  const std::string svg = svg_torque_plot({synthetic("run.csv", "")}, "host_id validate r.json");
  EXPECT_NE(svg.find(">run.csv</text>"), std::string::npos);
  EXPECT_EQ(svg.find("(fit:"), std::string::npos);
}

}  // namespace
}  // namespace host_id
