// Tests src/viz/EpisodeReport.cpp and ReportPage.cpp: the files of a report
// (page, maps, frames), the data inlined in the page, and the page itself in
// a real browser (headless Chromium: rows, frames, highlighted words, deep
// links, sorting, no script errors, a screenshot kept as a test artifact).

#include "viz/EpisodeReport.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <map>
#include <regex>

#include "common/FileIo.h"
#include "rollout/Evaluator.h"
#include "rollout/RolloutTestWorld.h"
#include "support/TestPaths.h"
#include "support/TestUtil.h"
#include "viz/ReportPage.h"

namespace vln::viz {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using rollout::test::rolloutTestWorld;
using rollout::test::testVocabulary;
using ::testing::HasSubstr;

// Replays the ground truth and "attends" to word (step mod words) at each
// step, so the page's highlighted word is known.
class AttentiveReplayAgent : public rollout::Agent {
 public:
  void reset(int env, const data::Episode& episode) override {
    cursor_[env] = {episode.episode_id, 0};
    words_[env] = data::unpaddedLength(episode.instruction.instruction_tokens);
  }
  std::vector<sim::Action> act(rollout::VectorEnv&,
                               std::span<const int> active) override {
    std::vector<sim::Action> actions;
    for (int env : active) {
      auto& [id, step] = cursor_.at(env);
      lastStep_[env] = step;
      actions.push_back(rolloutTestWorld().groundTruth.at(id).actions.at(
          static_cast<size_t>(step++)));
    }
    return actions;
  }
  bool needsObservations() const override { return false; }
  void keepInstructionAttention(bool keep) override { keep_ = keep; }
  std::vector<float> instructionAttention(int env) const override {
    if (!keep_) return {};
    const int n = words_.at(env);
    std::vector<float> weights(static_cast<size_t>(n),
                               0.5f / static_cast<float>(n));
    weights[static_cast<size_t>(lastStep_.at(env) % n)] += 0.5f;
    return weights;
  }

 private:
  bool keep_ = false;
  std::map<int, std::pair<int, int>> cursor_;
  std::map<int, int> words_, lastStep_;
};

// the REPORT object inlined in a page
json pageData(const fs::path& page) {
  const std::string html = common::readFile(page);
  const std::string start = "const REPORT = ";
  const size_t a = html.find(start);
  EXPECT_NE(a, std::string::npos);
  const size_t b = html.find(";\n", a);
  return json::parse(html.substr(a + start.size(), b - a - start.size()));
}

struct WrittenReport {
  vln::test::TempDir dir;
  fs::path page;
  rollout::EvaluationResult result;
};

// a report of the test world's 10 episodes, the first 3 in detail
const WrittenReport& writtenReport() {
  static const auto* report = [] {
    auto* r = new WrittenReport;
    const auto& w = rolloutTestWorld();
    static const data::Vocabulary vocabulary = testVocabulary();
    AttentiveReplayAgent agent;
    agent.keepInstructionAttention(true);
    ReportConfig config;
    config.dir = r->dir / "report" / "ckpt_3_val_seen";
    config.title = "ckpt.3.pth on val_seen";
    config.detail_episodes = 3;
    config.vocabulary = &vocabulary;
    EpisodeReport observer(config, &agent);
    rollout::VectorEnv envs(2, w.sim, w.task,
                            std::make_shared<rollout::SceneCache>(w.sim), 2);
    r->result =
        rollout::evaluateEpisodes(agent, envs, w.episodes, &w.groundTruth,
                                  rollout::EvalConfig{}, {}, &observer);
    r->page = observer.write();
    return r;
  }();
  return *report;
}

TEST(EpisodeReportTest, WritesPageMapsFramesAndData) {
  const WrittenReport& r = writtenReport();
  const auto& w = rolloutTestWorld();
  const fs::path dir = r.page.parent_path();
  EXPECT_EQ(r.page.filename(), "index.html");
  const json data = pageData(r.page);
  EXPECT_EQ(data["title"], "ckpt.3.pth on val_seen");
  ASSERT_EQ(data["episodes"].size(), w.episodes.size());
  EXPECT_EQ(data["details"].size(), 3u);
  EXPECT_NEAR(data["summary"]["success"].get<double>(),
              r.result.stats.mean.success, 1e-9);
  const data::Vocabulary vocabulary = testVocabulary();
  for (size_t i = 0; i < w.episodes.size(); ++i) {
    const json& e = data["episodes"][i];
    const std::string id = std::to_string(w.episodes[i].episode_id);
    EXPECT_EQ(e["id"], id);
    EXPECT_NEAR(e["metrics"]["spl"].get<double>(),
                r.result.episodes[i].metrics.spl, 1e-9);
    EXPECT_EQ(e["detail"].get<bool>(), i < 3);
    EXPECT_EQ(fs::exists(dir / ("maps/episode_" + id + ".png")), i < 3);
    if (i >= 3) continue;
    const json& d = data["details"][id];
    const int steps = r.result.episodes[i].record.steps_taken;
    EXPECT_EQ(d["frames"], steps + 1);
    EXPECT_EQ(d["actions"].size(), static_cast<size_t>(steps));
    EXPECT_EQ(d["path"].size(), static_cast<size_t>(steps + 1));
    // one JPEG per frame: RGB | depth, each 32 px
    EXPECT_EQ(vln::test::countEntries(dir / ("frames/episode_" + id)),
              steps + 1);
    const std::string jpeg =
        common::readFile(dir / ("frames/episode_" + id + "/step_000.jpg"));
    EXPECT_EQ(jpeg.substr(0, 2), "\xFF\xD8");
    // the words are the vocabulary's, the attention one row per action
    const auto& tokens = w.episodes[i].instruction.instruction_tokens;
    const int n = data::unpaddedLength(tokens);
    ASSERT_EQ(d["words"].size(), static_cast<size_t>(n));
    for (int k = 0; k < n; ++k)
      EXPECT_EQ(d["words"][static_cast<size_t>(k)],
                vocabulary.word(tokens[static_cast<size_t>(k)]));
    ASSERT_EQ(d["attention"].size(), static_cast<size_t>(steps));
    EXPECT_GT(d["attention"][1][static_cast<size_t>(1 % n)].get<double>(), 0.5);
  }
  const json summary = json::parse(common::readFile(dir / "report.json"));
  EXPECT_EQ(summary["episodes"], w.episodes.size());
}

TEST(EpisodeReportTest, DataCannotCloseTheScriptElement) {
  const json hostile = {
      {"title", "a </script><script>alert(1)</script> <!-- b"}};
  const std::string safe = scriptSafeJson(hostile);
  EXPECT_EQ(safe.find('<'), std::string::npos);
  EXPECT_EQ(json::parse(safe), hostile);
  const std::string page = reportPageHtml(hostile);
  EXPECT_THAT(page, HasSubstr("<title>a &lt;/script&gt;"));
  // the page's own script element is the only one that closes
  size_t closes = 0;
  for (size_t at = page.find("</script>"); at != std::string::npos;
       at = page.find("</script>", at + 1))
    ++closes;
  EXPECT_EQ(closes, 1u);
}

TEST(EpisodeReportTest, IndexListsEveryReport) {
  const WrittenReport& r = writtenReport();
  const fs::path root = r.page.parent_path().parent_path();
  vln::test::writeText(
      root / "random_val_seen" / "report.json",
      R"({"title": "random on val_seen", "episodes": 4, "episodes_scored": 4,
                           "summary": {"success": 0.25}})");
  const fs::path index = writeReportIndex(root);
  const std::string html = common::readFile(index);
  EXPECT_THAT(html, HasSubstr("ckpt_3_val_seen/index.html"));
  EXPECT_THAT(html, HasSubstr("random_val_seen/index.html"));
  vln::test::writeText(root / "broken" / "report.json", "{not json");
  EXPECT_THAT(vln::test::errorOf([&] { writeReportIndex(root); }),
              HasSubstr("broken/report.json' is not valid JSON"));
  fs::remove_all(root / "broken");
}

// ---------------------------------------------------------------------------
// in a real browser

std::string chromium() {
  for (const char* candidate :
       {"/usr/bin/chromium", "/usr/bin/chromium-browser"})
    if (fs::exists(candidate)) return candidate;
  return "";
}

// the DOM after the page's script ran, from `url`; the browser's own log
// (console messages included) goes to `log`
std::string dumpDom(const std::string& url, const fs::path& log) {
  std::string dom;
  const int status = vln::test::runCommand(
      chromium() +
          " --headless --no-sandbox --disable-gpu --disable-dev-shm-usage"
          " --enable-logging=stderr --v=0 --virtual-time-budget=5000"
          " --dump-dom '" +
          url + "' 2>" + log.string(),
      &dom);
  EXPECT_EQ(status, 0) << vln::test::readText(log);
  return dom;
}

std::vector<std::string> rowEpisodes(const std::string& dom) {
  std::vector<std::string> ids;
  const std::regex row(
      R"re(<tr class="episode-row[^"]*" data-episode="(\d+)")re");
  for (auto it = std::sregex_iterator(dom.begin(), dom.end(), row);
       it != std::sregex_iterator(); ++it)
    ids.push_back((*it)[1]);
  return ids;
}

TEST(EpisodeReportTest, OpensInHeadlessChromium) {
  if (chromium().empty())
    GTEST_SKIP() << "chromium is not installed (scripts/test.sh installs it)";
  const WrittenReport& r = writtenReport();
  const auto& w = rolloutTestWorld();
  vln::test::TempDir logs;
  const std::string id = std::to_string(w.episodes[1].episode_id);
  const std::string url =
      "file://" + r.page.string() + "#episode=" + id + "&step=2";
  const std::string dom = dumpDom(url, logs / "chromium.log");
  const std::string log = vln::test::readText(logs / "chromium.log");

  // the script ran to its end without an error
  EXPECT_THAT(dom, HasSubstr("data-ready=\"1\""));
  EXPECT_THAT(dom, ::testing::Not(HasSubstr("data-errors")));
  EXPECT_THAT(log, ::testing::Not(HasSubstr("Uncaught")));
  // a row per episode, the linked one selected
  EXPECT_EQ(rowEpisodes(dom).size(), w.episodes.size());
  EXPECT_THAT(
      dom,
      HasSubstr("class=\"episode-row has-detail selected\" data-episode=\"" +
                id + "\""));
  // its frame at step 2 and the word the agent attended to then
  EXPECT_THAT(dom, HasSubstr("src=\"frames/episode_" + id + "/step_002.jpg\""));
  const auto& tokens = w.episodes[1].instruction.instruction_tokens;
  const int n = data::unpaddedLength(tokens);
  const std::string top =
      testVocabulary().word(tokens[static_cast<size_t>(2 % n)]);
  const std::regex topWord(
      R"re(<span class="word top-word" data-index="(\d+)"[^>]*>([^<]*)</span>)re");
  std::smatch match;
  ASSERT_TRUE(std::regex_search(dom, match, topWord)) << "no highlighted word";
  EXPECT_EQ(match[1], std::to_string(2 % n));
  EXPECT_EQ(match[2], top);
  EXPECT_THAT(
      dom, HasSubstr("step 2 of " +
                     std::to_string(r.result.episodes[1].record.steps_taken)));

  // a deep link to a sort order: rows by SPL, highest first
  const std::string sorted =
      dumpDom("file://" + r.page.string() + "#sort=spl&order=desc",
              logs / "sorted.log");
  std::vector<std::pair<double, int>> bySpl;
  for (size_t i = 0; i < r.result.episodes.size(); ++i)
    bySpl.push_back({-r.result.episodes[i].metrics.spl, static_cast<int>(i)});
  std::sort(bySpl.begin(), bySpl.end());
  std::vector<std::string> expected;
  for (const auto& [spl, i] : bySpl)
    expected.push_back(
        std::to_string(w.episodes[static_cast<size_t>(i)].episode_id));
  EXPECT_EQ(rowEpisodes(sorted), expected);

  // a screenshot for people, kept with the build's test artifacts
  const fs::path artifacts = vln::test::binaryPath() / "tests" / "artifacts";
  fs::create_directories(artifacts);
  const fs::path shot = artifacts / "episode_report.png";
  fs::remove(shot);
  std::string output;
  EXPECT_EQ(
      vln::test::runCommand(
          chromium() +
              " --headless --no-sandbox --disable-gpu --disable-dev-shm-usage"
              " --hide-scrollbars --window-size=1400,1000"
              " --virtual-time-budget=5000 --screenshot=" +
              shot.string() + " '" + url + "'",
          &output),
      0)
      << output;
  ASSERT_TRUE(fs::exists(shot)) << output;
  EXPECT_GT(fs::file_size(shot), 20000u);
}

}  // namespace
}  // namespace vln::viz
