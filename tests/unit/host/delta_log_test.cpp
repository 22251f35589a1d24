#include "host_id/delta_log.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <sstream>
#include <string>
#include <vector>

#include "delta/input_error.hpp"

namespace host_id {
namespace {

const std::string kMeta =
    "# format = delta-log/1\n"
    "# upper_arm_length_m = 0.2\n"
    "# forearm_length_m = 0.46\n"
    "# base_radius_m = 0.1\n"
    "# platform_radius_m = 0.035\n";

// The message of the delta::InputError that parsing text throws, or "" if none.
std::string error_of(const std::string& text) {
  try {
    parse_delta_log(text, "log.csv");
  } catch (const delta::InputError& e) {
    return e.what();
  }
  return "";
}

TEST(DeltaLogTest, ReadsTheContractExample) {
  const std::string text = kMeta +
                           "# sample_rate_hz = 1000\n"
                           "t,q1,q2,q3,tau1,tau2,tau3\n"
                           "0.000,0.3121,0.2987,0.3050,0.8123,0.7990,0.8042\n"
                           "0.001,0.3122,0.2986,0.3051,0.8131,0.7985,0.8049\n";
  const DeltaLog log = parse_delta_log(text, "log.csv");
  ASSERT_EQ(log.size(), 2u);
  EXPECT_DOUBLE_EQ(log.geometry.forearm_length_m, 0.46);
  EXPECT_DOUBLE_EQ(log.gravity_m_s2, 9.81);
  EXPECT_DOUBLE_EQ(*log.sample_rate_hz, 1000.0);
  EXPECT_DOUBLE_EQ(log.q[1][1], 0.2986);
  EXPECT_DOUBLE_EQ(log.tau[2][0], 0.8042);
  EXPECT_FALSE(log.has_qd);
  EXPECT_TRUE(log.gaps.empty());
  EXPECT_EQ(log.first_data_line, 8u);
}

TEST(DeltaLogTest, ColumnsInAnyOrderCrLfUnknownKeysAndExtraColumnsAreKept) {
  const std::string text =
      "# format = delta-log/1\r\n# robot = cell7\r\n# upper_arm_length_m = 0.2\r\n"
      "# forearm_length_m = 0.46\r\n# a comment without equals sign\r\n"
      "# base_radius_m = 0.1\r\n# platform_radius_m = 0.035\r\n# colour = blue\r\n"
      "tau3,q3,x,tau1,q1,t,tau2,q2,seq\r\n"
      "3,0.3,9,1,0.1,0.5,2,0.2,7\r\n"
      "6,0.6,8,4,0.4,0.6,5,0.5,8\r\n";
  const DeltaLog log = parse_delta_log(text, "log.csv");
  ASSERT_EQ(log.size(), 2u);
  EXPECT_DOUBLE_EQ(log.t[1], 0.6);
  EXPECT_DOUBLE_EQ(log.q[0][1], 0.4);
  EXPECT_DOUBLE_EQ(log.tau[2][0], 3.0);
  ASSERT_EQ(log.seq.size(), 2u);
  EXPECT_EQ(log.seq[1], 8u);
  EXPECT_EQ(log.metadata_value("colour").value_or(""), "blue");
  EXPECT_EQ(log.metadata_value("robot").value_or(""), "cell7");
  ASSERT_EQ(log.extra_columns.size(), 1u);
  EXPECT_EQ(log.extra_columns[0].first, "x");
  EXPECT_DOUBLE_EQ(log.extra_columns[0].second[1], 8.0);
}

TEST(DeltaLogTest, WriterRoundTripsEveryDoubleExactly) {
  DeltaLog log;
  log.geometry = delta::kDefaultGeometry;
  log.sample_rate_hz = 1000.0;
  log.has_qd = log.has_qdd = true;
  for (int k = 0; k < 50; ++k) {
    log.t.push_back(k * 1e-3);
    log.seq.push_back(static_cast<std::uint64_t>(k));
    for (unsigned j = 0; j < 3; ++j) {
      log.q[j].push_back(0.1 * j + 1.0 / (3.0 + k));
      log.tau[j].push_back(-0.7 + 1e-17 * k + j / 7.0);
      log.qd[j].push_back(1.0 / (k + 1.0));
      log.qdd[j].push_back(-3.3e-5 * k);
    }
  }
  const DeltaLog back = parse_delta_log(format_delta_log(log), "round.csv");
  ASSERT_EQ(back.size(), log.size());
  for (std::size_t k = 0; k < log.size(); ++k) {
    EXPECT_EQ(back.t[k], log.t[k]);
    for (unsigned j = 0; j < 3; ++j) {
      EXPECT_EQ(back.q[j][k], log.q[j][k]);
      EXPECT_EQ(back.tau[j][k], log.tau[j][k]);
      EXPECT_EQ(back.qd[j][k], log.qd[j][k]);
      EXPECT_EQ(back.qdd[j][k], log.qdd[j][k]);
    }
  }
}

TEST(DeltaLogTest, MissingRequiredKeyIsNamed) {
  const std::string text =
      "# format = delta-log/1\n# upper_arm_length_m = 0.2\n# forearm_length_m = 0.46\n"
      "# base_radius_m = 0.1\nt,q1,q2,q3,tau1,tau2,tau3\n0,0,0,0,0,0,0\n";
  EXPECT_EQ(error_of(text),
            "log.csv:5:1: required metadata key 'platform_radius_m' is missing before the header "
            "(expected a line '# platform_radius_m = ...')");
}

TEST(DeltaLogTest, WrongFormatAndBadMetadataNumbers) {
  EXPECT_EQ(error_of("# format = delta-log/2\n"),
            "log.csv:1:12: unsupported format 'delta-log/2'; this reader reads delta-log/1");
  const std::string bad = "# format = delta-log/1\n# upper_arm_length_m = 0.2m\n";
  EXPECT_EQ(error_of(bad),
            "log.csv:2:24: metadata key 'upper_arm_length_m' must be a number in m, got '0.2m'");
  const std::string twice = kMeta + "# forearm_length_m = 0.5\n";
  EXPECT_NE(error_of(twice).find("log.csv:6:3: metadata key 'forearm_length_m' appears twice"),
            std::string::npos)
      << error_of(twice);
}

TEST(DeltaLogTest, InvalidGeometryIsRejectedWithTheReason) {
  const std::string text =
      "# format = delta-log/1\n# upper_arm_length_m = -0.2\n# forearm_length_m = 0.46\n"
      "# base_radius_m = 0.1\n# platform_radius_m = 0.035\nt,q1,q2,q3,tau1,tau2,tau3\n";
  EXPECT_NE(error_of(text).find("log.csv:2:1: invalid geometry in the metadata: upper_arm_length_m "
                                "must be a positive length, got -0.2"),
            std::string::npos)
      << error_of(text);
}

TEST(DeltaLogTest, MissingColumnAndPartialGroups) {
  EXPECT_EQ(error_of(kMeta + "t,q1,q2,q3,tau1,tau3\n"),
            "log.csv:6:1: required column 'tau2' is missing from the header; it has 6 column(s): "
            "'t', 'q1', 'q2', 'q3', 'tau1', 'tau3' (docs/log-format.md lists the columns)");
  EXPECT_EQ(error_of(kMeta + "t,q1,q2,q3,tau1,tau2,tau3,qd1,qd2\n"),
            "log.csv:6:1: columns qd1..qd3 must be given all three or none");
  EXPECT_EQ(error_of(kMeta + "t,q1,q2,q3,tau1,tau2,tau3,q1\n"),
            "log.csv:6:27: column 'q1' appears twice in the header");
}

// A header it cannot use is answered with what it has and the likely
// cause: another separator, quoted names, upper case, a pandas index.
TEST(DeltaLogTest, AnUnusableHeaderSaysWhatItHasAndWhy) {
  EXPECT_EQ(error_of(kMeta + "t;q1;q2;q3;tau1;tau2;tau3\n"),
            "log.csv:6:1: required column 't' is missing from the header; it has 1 column(s): "
            "'t;q1;q2;q3;tau1;tau2;tau3' (the names are separated by ';'; delta-log/1 separates "
            "them by ',', docs/log-format.md)");
  EXPECT_NE(error_of(kMeta + "t\tq1\tq2\tq3\ttau1\ttau2\ttau3\n")
                .find("(the names are separated by 'a tab'"),
            std::string::npos);
  EXPECT_EQ(error_of(kMeta + "\"t\",\"q1\",\"q2\",\"q3\",\"tau1\",\"tau2\",\"tau3\"\n"),
            "log.csv:6:1: required column 't' is missing from the header; it has 7 column(s): "
            "'\"t\"', '\"q1\"', '\"q2\"', '\"q3\"', '\"tau1\"', '\"tau2\"', '\"tau3\"' (the "
            "names are quoted; write them bare: t,q1,q2,q3,tau1,tau2,tau3)");
  EXPECT_EQ(error_of(kMeta + "T,Q1,Q2,Q3,TAU1,TAU2,TAU3\n"),
            "log.csv:6:1: required column 't' is missing from the header; it has 7 column(s): "
            "'T', 'Q1', 'Q2', 'Q3', 'TAU1', 'TAU2', 'TAU3' ('T': column names are lower case: "
            "'t')");
  EXPECT_EQ(error_of(kMeta + ",t,q1,q2,q3,tau1,tau2,tau3\n"),
            "log.csv:6:1: empty column name in the header (a first column without a name is what "
            "pandas writes for its index: write the CSV with index=False)");
}

// Rows at times 0, step, 2 step, ... (n of them), with optional seq
// holes: a sample whose index is in `dropped` is left out.
std::string rows(std::size_t n, double step, const std::vector<std::size_t>& dropped = {}) {
  std::string out = "seq,t,q1,q2,q3,tau1,tau2,tau3\n";
  for (std::size_t k = 0; k < n; ++k) {
    if (std::find(dropped.begin(), dropped.end(), k) != dropped.end()) continue;
    out +=
        std::to_string(k) + "," + format_number(step * static_cast<double>(k)) + ",0,0,0,1,1,1\n";
  }
  return out;
}

// A 500 Hz log that says 1000 Hz would be a gap at every sample: the
// declared rate is refused at its line, with the rate the times show.
TEST(DeltaLogTest, ADeclaredRateTheTimesContradictIsRefused) {
  EXPECT_EQ(error_of(kMeta + "# sample_rate_hz = 1000\n" + rows(40, 0.002)),
            "log.csv:6:1: sample_rate_hz = 1000 declares a step of 0.001 s, but 39 of the 39 time "
            "steps are longer than 1.5 of it (the median step is 0.002 s, 500 Hz): correct "
            "sample_rate_hz or remove it");
  // The same log declaring its own rate, or none, is read.
  EXPECT_EQ(error_of(kMeta + "# sample_rate_hz = 500\n" + rows(40, 0.002)), "");
  EXPECT_EQ(error_of(kMeta + rows(40, 0.002)), "");
}

// Every gap is a warning, but a log with hundreds prints ten and counts
// the rest.
TEST(DeltaLogTest, GapWarningsAreCappedWithACount) {
  std::vector<std::size_t> dropped;
  for (std::size_t k = 5; k < 400; k += 10) dropped.push_back(k);  // 40 lost samples
  const DeltaLog log = parse_delta_log(kMeta + rows(400, 0.001, dropped), "log.csv");
  ASSERT_EQ(log.gaps.size(), 40u);
  std::ostringstream err;
  warn_about_log(err, log);
  const std::string text = err.str();
  EXPECT_EQ(static_cast<std::size_t>(std::count(text.begin(), text.end(), '\n')),
            kGapWarningsShown + 1);
  EXPECT_NE(text.find("log.csv:12: warning: seq jumps from 4 to 6 (1 samples lost)"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("log.csv: warning: ... and 30 more gaps, up to line " +
                      std::to_string(log.gaps.back().line) + "\n"),
            std::string::npos)
      << text;
}

// qd without qdd (or the reverse) cannot be used: q is differentiated
// instead, and the user is told, not left to find out.
TEST(DeltaLogTest, ADerivativeGroupWithoutTheOtherIsSaidToBeUnused) {
  const DeltaLog log = parse_delta_log(
      kMeta + "t,q1,q2,q3,tau1,tau2,tau3,qd1,qd2,qd3\n0,0,0,0,0,0,0,0,0,0\n", "log.csv");
  std::ostringstream err;
  warn_about_log(err, log);
  EXPECT_EQ(err.str(),
            "log.csv: warning: the log has qd1..qd3 but not qdd1..qdd3, so qd1..qd3 are not used: "
            "q is filtered and differentiated (give both, or neither; docs/log-format.md)\n");
  const DeltaLog both = parse_delta_log(
      kMeta + "t,q1,q2,q3,tau1,tau2,tau3,qd1,qd2,qd3,qdd1,qdd2,qdd3\n0,0,0,0,0,0,0,0,0,0,0,0,0\n",
      "log.csv");
  std::ostringstream none;
  warn_about_log(none, both);
  EXPECT_EQ(none.str(), "");
}

// Columns the model does not read are kept, and said to be unused; the
// documented i1..i3 (the recorder's currents) go without saying.
TEST(DeltaLogTest, ColumnsTheModelDoesNotReadAreSaidToBeUnused) {
  const DeltaLog log = parse_delta_log(
      kMeta + "t,q1,q2,q3,tau1,tau2,tau3,temp1,i1,i2,i3,i_ref\n0,0,0,0,0,0,0,25,0,0,0,0\n",
      "log.csv");
  std::ostringstream err;
  warn_about_log(err, log);
  EXPECT_EQ(err.str(),
            "log.csv: warning: column(s) temp1, i_ref are not used by the model "
            "(docs/log-format.md lists the columns it reads)\n");
}

// Plain numbers take the reader's quick path, fields with spaces or a '+'
// its careful one: both give the same values.
TEST(DeltaLogTest, SpacesAndPlusSignsReadAsThePlainNumbers) {
  const std::string h = kMeta + "t,q1,q2,q3,tau1,tau2,tau3\n";
  const DeltaLog plain = parse_delta_log(h + "0,0.25,-1e-3,3,0.5,7,8\n", "a.csv");
  const DeltaLog spaced = parse_delta_log(h + "0, 0.25 ,-1e-3 , +3,0.5\t,+7,8 \n", "b.csv");
  for (unsigned j = 0; j < 3; ++j) {
    EXPECT_EQ(plain.q[j], spaced.q[j]);
    EXPECT_EQ(plain.tau[j], spaced.tau[j]);
  }
  EXPECT_EQ(plain.q[1][0], -1e-3);
  EXPECT_EQ(plain.tau[1][0], 7.0);
}

TEST(DeltaLogTest, NonNumbersNanInfAndFieldCountsNameLineAndColumn) {
  const std::string h = kMeta + "t,q1,q2,q3,tau1,tau2,tau3\n0,0,0,0,0,0,0\n";
  EXPECT_EQ(error_of(h + "0.001,0.1,abc,0,0,0,0\n"),
            "log.csv:8:11: column 'q2': not a number: 'abc'");
  EXPECT_EQ(error_of(h + "0.001,0.1,0.2,0,nan,0,0\n"),
            "log.csv:8:17: column 'tau1': NaN or Inf is not allowed");
  EXPECT_EQ(error_of(h + "0.001,0.1,0.2,0,0,inf,0\n"),
            "log.csv:8:19: column 'tau2': NaN or Inf is not allowed");
  EXPECT_EQ(error_of(h + "0.001,0.1,0.2,0,0,0\n"),
            "log.csv:8:20: row has 6 fields, the header has 7");
  EXPECT_EQ(error_of(h + "0.001,0.1,0.2,0,0,0,0,9\n"),
            "log.csv:8:22: row has 8 fields, the header has 7");
  EXPECT_EQ(error_of(h + "0.001,0.1,,0,0,0,0\n"), "log.csv:8:11: column 'q2': empty field");
  EXPECT_EQ(error_of(h + "0.001,0.1,0x10,0,0,0,0\n"),
            "log.csv:8:11: column 'q2': not a number: '0x10'");
  // One sign at most: '+-1' is not -1 (it was, once).
  EXPECT_EQ(error_of(h + "0.001,0.1,+-1,0,0,0,0\n"),
            "log.csv:8:11: column 'q2': not a number: '+-1'");
  EXPECT_EQ(error_of(h + "0.001,0.1,++1,0,0,0,0\n"),
            "log.csv:8:11: column 'q2': not a number: '++1'");
  EXPECT_EQ(error_of(h + "0.001,0.1,-+1,0,0,0,0\n"),
            "log.csv:8:11: column 'q2': not a number: '-+1'");
}

// The format is UTF-8 text: a metadata value, a comment or a column name
// that is not is refused at its byte (a fuzzing finding of #19); UTF-8 such
// as a robot named "Roboter-Ä" is fine.
TEST(DeltaLogTest, TextThatIsNotUtf8IsRefusedAtItsByte) {
  const std::string rows = "t,q1,q2,q3,tau1,tau2,tau3\n0,0,0,0,0,0,0\n";
  EXPECT_EQ(error_of(kMeta + "# robot = caf\xE9\n" + rows),
            "log.csv:6:14: not UTF-8 text (byte 0xE9)");
  EXPECT_EQ(error_of(kMeta + "# a comment \xC0\xAF\n" + rows),
            "log.csv:6:13: not UTF-8 text (byte 0xC0)");  // an overlong '/'
  EXPECT_EQ(error_of(kMeta + "t,q1,q2,q3,tau1,tau2,tau3,x\xED\xA0\x80\n0,0,0,0,0,0,0,0\n"),
            "log.csv:6:28: not UTF-8 text (byte 0xED)");  // a surrogate
  EXPECT_EQ(error_of(kMeta + "# robot = Roboter-\xC3\x84 \xF0\x9F\xA4\x96\n" + rows), "");
}

TEST(DeltaLogTest, TimeMustIncrease) {
  const std::string h = kMeta + "t,q1,q2,q3,tau1,tau2,tau3\n0.5,0,0,0,0,0,0\n";
  EXPECT_EQ(error_of(h + "0.5,0,0,0,0,0,0\n"),
            "log.csv:8:1: column 't': time 0.5 s is not after the previous sample's 0.5 s");
  EXPECT_EQ(error_of(h + "0.4,0,0,0,0,0,0\n"),
            "log.csv:8:1: column 't': time 0.4 s is not after the previous sample's 0.5 s");
}

TEST(DeltaLogTest, SeqAndTimeGapsAreReportedNotBridged) {
  const std::string text = kMeta + "# sample_rate_hz = 1000\nseq,t,q1,q2,q3,tau1,tau2,tau3\n" +
                           "10,0.000,0,0,0,0,0,0\n11,0.001,0,0,0,0,0,0\n"
                           "15,0.005,0,0,0,0,0,0\n16,0.006,0,0,0,0,0,0\n"
                           "17,0.010,0,0,0,0,0,0\n";
  const DeltaLog log = parse_delta_log(text, "log.csv");
  ASSERT_EQ(log.gaps.size(), 2u);
  EXPECT_EQ(log.gaps[0].index, 2u);
  EXPECT_EQ(log.gaps[0].line, 10u);
  EXPECT_EQ(log.gaps[0].what, "seq jumps from 11 to 15 (3 samples lost)");
  EXPECT_EQ(log.gaps[1].index, 4u);
  EXPECT_NE(log.gaps[1].what.find("time jumps by 0.004 s"), std::string::npos) << log.gaps[1].what;
  EXPECT_EQ(error_of(kMeta + "seq,t,q1,q2,q3,tau1,tau2,tau3\n5,0,0,0,0,0,0,0\n5,1,0,0,0,0,0,0\n"),
            "log.csv:8:1: column 'seq': 5 does not increase (previous 5)");
}

TEST(DeltaLogTest, EmptyAndTruncatedFiles) {
  EXPECT_EQ(error_of(""), "log.csv:1:1: no header row: the file has no line of column names");
  EXPECT_EQ(error_of(kMeta + "t,q1,q2,q3,tau1,tau2,tau3\n"),
            "log.csv:6:1: no data rows after the header");
  EXPECT_EQ(error_of(kMeta + "t,q1,q2,q3,tau1,tau2,tau3\n0,0,0,0,0,0,0\n\n1,0,0,0,0,0,0\n"),
            "log.csv:8:1: empty line inside the file (only allowed at the end)");
  // A header as the last line, without its '\n' (read past the text once).
  EXPECT_EQ(error_of(kMeta + "t,q1,q2,q3,tau1,tau2,tau3"),
            "log.csv:6:1: no data rows after the header");
  // Blank lines at the end are fine.
  EXPECT_EQ(error_of(kMeta + "t,q1,q2,q3,tau1,tau2,tau3\n0,0,0,0,0,0,0\n\n\n"), "");
}

TEST(DeltaLogTest, MissingFileIsNamed) {
  try {
    read_delta_log("/nonexistent/dir/log.csv");
    FAIL();
  } catch (const delta::InputError& e) {
    EXPECT_EQ(std::string(e.what()),
              "/nonexistent/dir/log.csv: cannot open: No such file or directory");
  }
}

}  // namespace
}  // namespace host_id
