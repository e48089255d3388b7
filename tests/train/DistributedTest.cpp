// Tests of src/train/Distributed.cpp and of the learner's multi-process
// mode, with two ranks as two threads of this process over a c10d FileStore
// (and over TCPStores: rank 0's and torchrun's agent's): the torchrun
// variables and their errors, bucketed gradient averaging, broadcasts, the
// all-gather of byte strings, reductions, the identity check, error
// propagation, waits and aborts, an unreachable master; then two
// ImitationLearners on parts of batches (even and uneven) against one
// learner on the whole batch.

#include "train/Distributed.h"

#include <ATen/CPUGeneratorImpl.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <torch/csrc/distributed/c10d/TCPStore.hpp>

#include <array>
#include <cmath>
#include <map>
#include <thread>

#include "common/Check.h"
#include "support/TestPaths.h"
#include "support/TestUtil.h"
#include "train/Checkpoint.h"
#include "train/ImitationLearner.h"
#include "train/LearnerTestUtil.h"

namespace vln::train {
namespace {

namespace fs = std::filesystem;
using test::layoutOf;
using test::tinyLearnerConfig;
using ::testing::HasSubstr;
using vln::test::freePort;

DistributedOptions testOptions() {
  DistributedOptions o;
  // a broken test fails within seconds instead of hanging
  o.timeout = std::chrono::seconds(30);
  o.wait_timeout = std::chrono::seconds(30);
  return o;
}

// runs body(rank) for ranks 0 and 1 on two threads; returns each rank's
// exception (null when it returned)
std::array<std::exception_ptr, 2> onTwoThreads(
    const std::function<void(int)>& body) {
  std::array<std::exception_ptr, 2> errors;
  std::array<std::thread, 2> threads;
  for (int r = 0; r < 2; ++r)
    threads[static_cast<size_t>(r)] = std::thread([&, r] {
      try {
        body(r);
      } catch (...) {
        errors[static_cast<size_t>(r)] = std::current_exception();
      }
    });
  for (auto& t : threads) t.join();
  return errors;
}

// runs body(dist) on ranks 0 and 1 (threads) over one FileStore
std::array<std::exception_ptr, 2> onTwoRanks(
    const std::function<void(Distributed&)>& body,
    DistributedOptions options = testOptions()) {
  vln::test::TempDir dir;
  return onTwoThreads([&](int r) {
    auto dist = Distributed::overFileStore(dir / "store", r, 2, options);
    body(*dist);
  });
}

// rank `rank` of two whose master is on loopback at `port`
DistributedEnv loopbackEnv(int rank, int port) {
  DistributedEnv env;
  env.rank = rank;
  env.world_size = 2;
  env.master_addr = "127.0.0.1";
  env.master_port = port;
  return env;
}

std::string messageOf(const std::exception_ptr& error) {
  if (!error) return "<no exception>";
  try {
    std::rethrow_exception(error);
  } catch (const std::exception& e) {
    return e.what();
  }
  return "<not a std::exception>";
}

void expectNoErrors(const std::array<std::exception_ptr, 2>& errors) {
  for (int r = 0; r < 2; ++r)
    EXPECT_FALSE(errors[static_cast<size_t>(r)])
        << "rank " << r << ": " << messageOf(errors[static_cast<size_t>(r)]);
}

// ---------------------------------------------------------------------------
// the torchrun variables

std::optional<DistributedEnv> parse(
    const std::map<std::string, std::string>& vars) {
  return parseDistributedEnv([&](const char* name) -> const char* {
    auto it = vars.find(name);
    return it == vars.end() ? nullptr : it->second.c_str();
  });
}

TEST(DistributedTest, ParsesTorchrunVariables) {
  EXPECT_FALSE(parse({}).has_value());
  EXPECT_FALSE(parse({{"WORLD_SIZE", "1"}}).has_value());
  const auto env = parse({{"WORLD_SIZE", "4"},
                          {"RANK", "3"},
                          {"MASTER_ADDR", "10.0.0.7"},
                          {"MASTER_PORT", "29500"}});
  ASSERT_TRUE(env.has_value());
  EXPECT_EQ(env->world_size, 4);
  EXPECT_EQ(env->rank, 3);
  EXPECT_EQ(env->local_rank, 3);  // RANK when LOCAL_RANK is unset
  EXPECT_EQ(env->master_addr, "10.0.0.7");
  EXPECT_EQ(env->master_port, 29500);
  EXPECT_EQ(parse({{"WORLD_SIZE", "4"},
                   {"RANK", "3"},
                   {"LOCAL_RANK", "1"},
                   {"MASTER_ADDR", "h"},
                   {"MASTER_PORT", "1"}})
                ->local_rank,
            1);
  EXPECT_FALSE(env->use_agent_store);
  // torchrun's static rendezvous: its agent hosts the store
  const auto agent = parse({{"WORLD_SIZE", "2"},
                            {"RANK", "0"},
                            {"MASTER_ADDR", "h"},
                            {"MASTER_PORT", "29500"},
                            {"TORCHELASTIC_USE_AGENT_STORE", "True"},
                            {"TORCHELASTIC_RESTART_COUNT", "3"}});
  ASSERT_TRUE(agent.has_value());
  EXPECT_TRUE(agent->use_agent_store);
  EXPECT_EQ(agent->restart_count, 3);
  EXPECT_FALSE(parse({{"WORLD_SIZE", "2"},
                      {"RANK", "0"},
                      {"MASTER_ADDR", "h"},
                      {"MASTER_PORT", "29500"},
                      {"TORCHELASTIC_USE_AGENT_STORE", "False"}})
                   ->use_agent_store);
}

TEST(DistributedTest, BadTorchrunVariablesAreNamed) {
  auto error = [](const std::map<std::string, std::string>& vars) {
    try {
      parse(vars);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("<no error>");
  };
  const std::map<std::string, std::string> good = {{"WORLD_SIZE", "2"},
                                                   {"RANK", "1"},
                                                   {"MASTER_ADDR", "host"},
                                                   {"MASTER_PORT", "29500"}};
  auto without = [&](const std::string& key) {
    auto vars = good;
    vars.erase(key);
    return vars;
  };
  auto with = [&](const std::string& key, const std::string& value) {
    auto vars = good;
    vars[key] = value;
    return vars;
  };
  EXPECT_THAT(
      error(without("RANK")),
      HasSubstr("WORLD_SIZE=2 but environment variable RANK is not set"));
  EXPECT_THAT(error(without("MASTER_ADDR")),
              HasSubstr("MASTER_ADDR is not set"));
  EXPECT_THAT(error(without("MASTER_PORT")),
              HasSubstr("MASTER_PORT is not set"));
  EXPECT_THAT(error(with("WORLD_SIZE", "two")),
              HasSubstr("WORLD_SIZE='two' is not an integer"));
  EXPECT_THAT(error(with("RANK", "2")), HasSubstr("RANK=2 is outside [0, 1]"));
  EXPECT_THAT(error(with("RANK", "-1")), HasSubstr("RANK=-1 is outside"));
  EXPECT_THAT(error(with("MASTER_PORT", "70000")),
              HasSubstr("MASTER_PORT=70000 is outside [1, 65535]"));
  EXPECT_THAT(error(with("MASTER_PORT", "29500x")),
              HasSubstr("MASTER_PORT='29500x' is not an integer"));
  EXPECT_THAT(error(with("LOCAL_RANK", "")), HasSubstr("<no error>"));
}

// ---------------------------------------------------------------------------
// collectives

TEST(DistributedTest, AveragesGradientsInBucketsOfMixedDtypes) {
  // rank r's gradients: (r + 1) * base; parameter 1 has none on rank 1,
  // parameter 3 none anywhere. 16-byte buckets split the float32 tensors
  // over several collectives, the float64 one goes alone.
  DistributedOptions options = testOptions();
  options.bucket_bytes = 16;
  std::array<std::vector<torch::Tensor>, 2> results;
  const auto errors = onTwoRanks(
      [&](Distributed& dist) {
        const int r = dist.rank();
        std::vector<torch::Tensor> params = {
            torch::zeros({3}, torch::kFloat32).requires_grad_(),
            torch::zeros({2, 3}, torch::kFloat32).requires_grad_(),
            torch::zeros({5}, torch::kFloat64).requires_grad_(),
            torch::zeros({2}, torch::kFloat32).requires_grad_(),
            torch::zeros({1}, torch::kFloat32).requires_grad_()};
        params[0].mutable_grad() = torch::arange(3, torch::kFloat32) * (r + 1);
        if (r == 0) params[1].mutable_grad() = torch::full({2, 3}, 6.0f);
        params[2].mutable_grad() =
            torch::linspace(0.5, 2.5, 5, torch::kFloat64) * (r + 1);
        params[4].mutable_grad() =
            torch::full({1}, 1.0f + static_cast<float>(r));
        dist.averageGradients(params);
        for (const auto& p : params)
          results[static_cast<size_t>(r)].push_back(p.grad());
      },
      options);
  expectNoErrors(errors);
  for (int r = 0; r < 2; ++r) {
    const auto& g = results[static_cast<size_t>(r)];
    ASSERT_EQ(g.size(), 5u);
    // mean of 1x and 2x is 1.5x
    EXPECT_TRUE(torch::allclose(g[0], torch::arange(3, torch::kFloat32) * 1.5));
    // defined on rank 0 only: (6 + 0) / 2
    EXPECT_TRUE(torch::equal(g[1], torch::full({2, 3}, 3.0f)));
    EXPECT_EQ(g[2].scalar_type(), torch::kFloat64);
    EXPECT_TRUE(torch::allclose(
        g[2], torch::linspace(0.5, 2.5, 5, torch::kFloat64) * 1.5));
    EXPECT_FALSE(g[3].defined()) << "no rank had a gradient: Adam skips it";
    EXPECT_FLOAT_EQ(g[4].item<float>(), 1.5f);
  }
}

TEST(DistributedTest, BroadcastsModulesOptimizerStateAndBytes) {
  std::array<std::string, 2> optimizerBytes;
  std::array<std::vector<torch::Tensor>, 2> weights;
  std::array<std::array<std::string, 3>, 2> received;
  const auto errors = onTwoRanks([&](Distributed& dist) {
    const int r = dist.rank();
    torch::manual_seed(static_cast<uint64_t>(10 + r));  // different inits
    torch::nn::Sequential net(torch::nn::Linear(4, 3),
                              torch::nn::BatchNorm1d(3));
    torch::optim::Adam adam(net->parameters(), torch::optim::AdamOptions(0.1));
    if (r == 0) {
      // rank 0 has taken one step: moments and step counts to send
      net->forward(torch::randn({5, 4})).sum().backward();
      adam.step();
    }
    dist.broadcastModule(*net.ptr());
    dist.broadcastOptimizer(adam);
    optimizerBytes[static_cast<size_t>(r)] = serializeOptimizer(adam);
    for (const auto& p : net->parameters())
      weights[static_cast<size_t>(r)].push_back(p.detach().clone());
    for (const auto& b : net->buffers())
      weights[static_cast<size_t>(r)].push_back(b.clone());
    auto& got = received[static_cast<size_t>(r)];
    got[0] = dist.broadcastBytes(r == 0 ? "from rank 0" : "ignored");
    got[1] = dist.broadcastBytes(r == 1 ? std::string("\0x\0", 3) : "", 1);
    got[2] = dist.broadcastBytes(r == 0 ? "" : "ignored");
  });
  expectNoErrors(errors);
  ASSERT_EQ(weights[0].size(), weights[1].size());
  for (size_t i = 0; i < weights[0].size(); ++i)
    EXPECT_TRUE(torch::equal(weights[0][i], weights[1][i])) << "tensor " << i;
  EXPECT_FALSE(optimizerBytes[0].empty());
  EXPECT_EQ(optimizerBytes[0], optimizerBytes[1]);
  for (int r = 0; r < 2; ++r) {
    EXPECT_EQ(received[static_cast<size_t>(r)][0], "from rank 0");
    EXPECT_EQ(received[static_cast<size_t>(r)][1], std::string("\0x\0", 3));
    EXPECT_EQ(received[static_cast<size_t>(r)][2], "");
  }
}

TEST(DistributedTest, AllGathersByteStringsOfDifferentLengthsInRankOrder) {
  // a long string with every byte value, so padding or truncation shows
  std::string long1(100003, '\0');
  for (size_t i = 0; i < long1.size(); ++i)
    long1[i] = static_cast<char>((i * 7) % 256);
  const std::array<std::array<std::string, 2>, 3> sent = {
      {{"from rank 0", std::string("\0x\0", 3)}, {"", ""}, {"", long1}}};
  std::array<std::array<std::vector<std::string>, 3>, 2> received;
  const auto errors = onTwoRanks([&](Distributed& dist) {
    const auto r = static_cast<size_t>(dist.rank());
    for (size_t call = 0; call < sent.size(); ++call)
      received[r][call] = dist.allGatherBytes(sent[call][r]);
  });
  expectNoErrors(errors);
  for (size_t r = 0; r < 2; ++r)
    for (size_t call = 0; call < sent.size(); ++call)
      EXPECT_EQ(received[r][call],
                (std::vector<std::string>{sent[call][0], sent[call][1]}))
          << "rank " << r << ", call " << call;
}

TEST(DistributedTest, ReducesMetricsAndDetectsDivergedTensors) {
  std::array<std::vector<double>, 2> sums;
  std::array<std::vector<int64_t>, 2> maxima;
  // drawn here: the ranks are threads, which would share the global
  // generator's draws between them
  torch::manual_seed(4);
  const torch::Tensor a0 = torch::randn({1000});
  const torch::Tensor b0 = torch::randn({3, 7}).to(torch::kFloat64);
  const auto errors = onTwoRanks([&](Distributed& dist) {
    const int r = dist.rank();
    sums[static_cast<size_t>(r)] = dist.allReduceSum({1.0 + r, 0.25, -3.0 * r});
    maxima[static_cast<size_t>(r)] = dist.allReduceMax({r, -r, 7});
    torch::Tensor a = a0.clone();
    torch::Tensor b = b0.clone();
    torch::Tensor c = torch::arange(5);
    // identical everywhere: passes
    dist.checkIdentical({a, b, c}, {"a", "b", "c"}, "in the first check");
    // one ulp of one element of b on rank 1: every rank throws
    if (r == 1) b[1][2] = std::nextafter(b[1][2].item<double>(), 1e9);
    dist.checkIdentical({a, b, c}, {"a", "b", "c"}, "in the second check");
  });
  for (int r = 0; r < 2; ++r) {
    EXPECT_EQ(sums[static_cast<size_t>(r)],
              (std::vector<double>{3.0, 0.5, -3.0}));
    EXPECT_EQ(maxima[static_cast<size_t>(r)], (std::vector<int64_t>{1, 0, 7}));
    EXPECT_THAT(messageOf(errors[static_cast<size_t>(r)]),
                HasSubstr("copies of 'b' differ in the second check"));
  }
}

TEST(DistributedTest, CollectivelyGivesEveryRankTheFirstFailure) {
  const auto errors = onTwoRanks([&](Distributed& dist) {
    dist.collectively("a step that works", [] {});
    dist.collectively("loading the data", [&] {
      if (dist.rank() == 1)
        throw std::invalid_argument("episode 12 has no goals");
    });
  });
  EXPECT_THAT(messageOf(errors[0]),
              HasSubstr("rank 1 failed during loading the data: episode 12 "
                        "has no goals"));
  EXPECT_EQ(messageOf(errors[1]), "episode 12 has no goals");
}

TEST(DistributedTest, WaitForAllEndsWithAnotherRanksAbortOrItsTimeout) {
  // rank 1 fails and says so: rank 0 stops waiting with its message
  auto errors = onTwoRanks([&](Distributed& dist) {
    dist.waitForAll("the start");
    if (dist.rank() == 1) {
      dist.abort("the disk is full");
      return;
    }
    dist.waitForAll("the end of collection round 3");
  });
  EXPECT_THAT(messageOf(errors[0]),
              HasSubstr("stopped while waiting for every rank at 'the end of "
                        "collection round 3' because rank 1 failed: the disk "
                        "is full"));
  EXPECT_FALSE(errors[1]) << messageOf(errors[1]);

  // rank 1 is just late: rank 0 gives up after wait_timeout
  DistributedOptions options = testOptions();
  options.wait_timeout = std::chrono::milliseconds(300);
  errors = onTwoRanks(
      [&](Distributed& dist) {
        if (dist.rank() == 0)
          dist.waitForAll("the evaluation");
        else
          std::this_thread::sleep_for(std::chrono::milliseconds(800));
      },
      options);
  EXPECT_THAT(messageOf(errors[0]),
              HasSubstr("for every rank at 'the evaluation': 1 of 2 arrived "
                        "(trainer.distributed_wait_s = 0.3)"));
  EXPECT_FALSE(errors[1]);
}

TEST(DistributedTest, RendezvousThroughTcpStoreAndAnUnreachableMaster) {
  const int port = freePort();
  std::array<std::vector<double>, 2> sums;
  const auto errors = onTwoThreads([&](int r) {
    auto dist = Distributed::connect(loopbackEnv(r, port), testOptions());
    EXPECT_EQ(dist->backendName(), "gloo");
    sums[static_cast<size_t>(r)] = dist->allReduceSum({2.0 * (r + 1)});
    dist->waitForAll("the end");
  });
  expectNoErrors(errors);
  EXPECT_EQ(sums[0], std::vector<double>{6.0});
  EXPECT_EQ(sums[1], std::vector<double>{6.0});

  // a rank whose master never comes names the address and the timeout
  const DistributedEnv env = loopbackEnv(1, freePort());
  DistributedOptions options = testOptions();
  options.timeout = std::chrono::milliseconds(1500);
  EXPECT_THAT(
      [&] { Distributed::connect(env, options); },
      ::testing::ThrowsMessage<std::runtime_error>(HasSubstr(strCat(
          "rank 1 could not reach the master at MASTER_ADDR:MASTER_PORT = "
          "127.0.0.1:",
          env.master_port, " within 1.5 s"))));
}

TEST(DistributedTest, JoinsThroughTorchrunsAgentStore) {
  // torchrun's agent (here: this thread) hosts the store on MASTER_PORT;
  // rank 0 must not try to host another one there
  const int port = freePort();
  c10d::TCPStoreOptions agentOptions;
  agentOptions.port = static_cast<uint16_t>(port);
  agentOptions.isServer = true;
  agentOptions.waitWorkers = false;
  auto agent = c10::make_intrusive<c10d::TCPStore>("127.0.0.1", agentOptions);
  // a key of an earlier attempt does not disturb this one
  agent->set("/worker/attempt_0/vln/abort", std::vector<uint8_t>{'x'});
  std::array<std::vector<double>, 2> sums;
  const auto errors = onTwoThreads([&](int r) {
    DistributedEnv env = loopbackEnv(r, port);
    env.use_agent_store = true;
    env.restart_count = 1;
    auto dist = Distributed::connect(env, testOptions());
    sums[static_cast<size_t>(r)] = dist->allReduceSum({1.0 + r});
    dist->waitForAll("the end");
  });
  expectNoErrors(errors);
  EXPECT_EQ(sums[0], std::vector<double>{3.0});
  EXPECT_EQ(sums[1], std::vector<double>{3.0});
  EXPECT_TRUE(agent->check({"/worker/attempt_1/vln/wait/0"}));
}

// ---------------------------------------------------------------------------
// the learner on two ranks

// episodes of different lengths whose label is readable from the depth map
void fillStore(FeatureStore& store, const ExperimentConfig& c, int first,
               int count) {
  const auto r = models::rgbFeatureShape(c.model);
  const auto d = models::depthFeatureShape(c.model);
  for (int i = first; i < first + count; ++i) {
    // a generator of its own: ranks are threads of this process
    const at::Generator gen =
        at::detail::createCPUGenerator(static_cast<uint64_t>(100 + i));
    StoredEpisode e;
    e.key.episode_id = i;
    e.key.slot = i;
    const int T = 3 + (i * 7) % 6;
    e.tokens = {1 + i % 10, 2, 3};
    e.rgb = torch::rand({T, r[0], r[1], r[2]}, gen);
    e.depth = torch::rand({T, d[0], d[1], d[2]}, gen);
    test::setMadeUpActions(e, i, T);
    store.append(e);
  }
}

std::vector<torch::Tensor> snapshot(models::PolicyImpl& policy) {
  std::vector<torch::Tensor> values;
  for (const auto& p : policy.parameters())
    values.push_back(p.detach().clone());
  return values;
}

// sqrt(sum of squared differences) over all tensors
double distance(const std::vector<torch::Tensor>& a,
                const std::vector<torch::Tensor>& b) {
  double squares = 0.0;
  for (size_t i = 0; i < a.size(); ++i)
    squares += (a[i] - b[i]).to(torch::kFloat64).pow(2).sum().item<double>();
  return std::sqrt(squares);
}

double maxAbsDifference(const std::vector<torch::Tensor>& a,
                        const std::vector<torch::Tensor>& b) {
  double m = 0.0;
  for (size_t i = 0; i < a.size(); ++i)
    m = std::max(m, (a[i] - b[i]).abs().max().item<double>());
  return m;
}

TEST(DistributedTest, TwoRanksOnPartsOfBatchesMatchOneProcessOnTheWholeBatch) {
  torch::set_num_threads(1);
  const ExperimentConfig c = tinyLearnerConfig(2);
  vln::test::TempDir dir;
  FeatureStore store(dir / "store", layoutOf(c), 0.05);
  fillStore(store, c, 0, 12);
  // three updates on whole batches of 4 episodes of different lengths
  const std::vector<std::vector<int64_t>> whole = {
      {0, 1, 2, 3}, {4, 5, 6, 7}, {8, 9, 10, 11}};

  torch::manual_seed(7);
  auto initial = models::makePolicy(c.model);
  const std::vector<torch::Tensor> start = snapshot(*initial);
  auto freshPolicy = [&] {
    auto p = models::makePolicy(c.model);
    models::loadStateStrict(*p, models::namedState(*initial), "initial");
    return p;
  };

  // one process on the whole batches
  auto single = freshPolicy();
  ImitationLearner singleLearner(single, c);
  std::vector<UpdateResult> singleResults;
  for (const auto& batch : whole)
    singleResults.push_back(singleLearner.update(store.loadBatch(batch)));
  const std::vector<torch::Tensor> singleEnd = snapshot(*single);
  const double moved = distance(singleEnd, start);
  ASSERT_GT(moved, 1e-3);

  // rank 0 takes the first `split` episodes of each batch, rank 1 the rest
  // (rank 1 starts from other weights: the broadcast must fix that)
  for (const int split : {2, 3}) {
    SCOPED_TRACE(strCat("rank 0 takes ", split, " of 4 episodes"));
    auto part = [&](size_t u, int rank) {
      const auto& w = whole[u];
      return rank == 0 ? std::vector<int64_t>(w.begin(), w.begin() + split)
                       : std::vector<int64_t>(w.begin() + split, w.end());
    };
    std::array<std::vector<torch::Tensor>, 2> rankEnd;
    std::array<std::vector<UpdateResult>, 2> rankResults;
    const auto errors = onTwoRanks([&](Distributed& dist) {
      const int r = dist.rank();
      auto policy = r == 0 ? freshPolicy() : models::makePolicy(c.model);
      ImitationLearner learner(policy, c);
      learner.setDistributed(&dist);
      dist.broadcastModule(*policy);
      for (size_t u = 0; u < whole.size(); ++u)
        rankResults[static_cast<size_t>(r)].push_back(
            learner.update(store.loadBatch(part(u, r))));
      rankEnd[static_cast<size_t>(r)] = snapshot(*policy);
    });
    expectNoErrors(errors);

    // the ranks are bitwise identical
    ASSERT_EQ(rankEnd[0].size(), singleEnd.size());
    for (size_t i = 0; i < singleEnd.size(); ++i)
      EXPECT_TRUE(torch::equal(rankEnd[0][i], rankEnd[1][i]))
          << "parameter " << i;
    // ... and equal to one process up to float rounding: each rank's action
    // loss (a mean over its episodes) and progress loss (a mean over its
    // steps) are weighted by its share of the episodes and steps
    EXPECT_LT(distance(rankEnd[0], singleEnd), 1e-4 * moved);
    EXPECT_LT(maxAbsDifference(rankEnd[0], singleEnd), 1e-5);
    for (size_t u = 0; u < whole.size(); ++u)
      for (int r = 0; r < 2; ++r) {
        const UpdateResult& d = rankResults[static_cast<size_t>(r)][u];
        const UpdateResult& s = singleResults[u];
        EXPECT_NEAR(d.loss, s.loss, 1e-5 * s.loss);
        EXPECT_NEAR(d.action_loss, s.action_loss, 1e-5 * s.action_loss);
        EXPECT_NEAR(d.progress_loss, s.progress_loss, 1e-5 * s.progress_loss);
        EXPECT_NEAR(d.grad_norm, s.grad_norm, 1e-4 * s.grad_norm);
        EXPECT_EQ(d.episodes, 4);
        EXPECT_EQ(d.steps, s.steps);
      }
  }

  // the control: one rank's part batches alone land far away, so the
  // comparison above can tell combined gradients from a rank's own
  auto alone = freshPolicy();
  ImitationLearner aloneLearner(alone, c);
  for (const auto& batch : whole)
    aloneLearner.update(
        store.loadBatch(std::vector<int64_t>{batch[0], batch[1]}));
  EXPECT_GT(distance(snapshot(*alone), singleEnd), 0.05 * moved);
}

TEST(DistributedTest,
     UnevenShardsTrainEqualUpdatesAndNonFiniteLossesSkipEverywhere) {
  torch::set_num_threads(1);
  const ExperimentConfig c = tinyLearnerConfig(2);
  vln::test::TempDir dir;
  std::array<EpochResult, 2> epochs;
  std::array<int64_t, 2> updates{}, nonFinite{};
  std::array<std::vector<torch::Tensor>, 2> ends;
  std::array<bool, 2> skippedFirst{};
  const auto errors = onTwoRanks([&](Distributed& dist) {
    const int r = dist.rank();
    // rank 0 holds 5 episodes (3 batches of 2), rank 1 holds 3 (2 batches)
    FeatureStore store(dir / ("shard" + std::to_string(r)), layoutOf(c), 0.05);
    fillStore(store, c, r == 0 ? 0 : 5, r == 0 ? 5 : 3);
    // every rank starts from rank 0's weights, as in the trainer
    auto policy = models::makePolicy(c.model);
    dist.broadcastModule(*policy);
    ImitationLearner learner(policy, c);
    learner.setDistributed(&dist);
    // rank 1's first loss is NaN: the first update is skipped on both
    int calls = 0;
    learner.setLossHook([&](const torch::Tensor& loss) {
      return r == 1 && calls++ == 0 ? loss * std::nan("") : loss;
    });
    const auto before = snapshot(*policy);
    bool first = true;
    epochs[static_cast<size_t>(r)] =
        learner.trainEpoch(store, 3, 0, [&](const UpdateResult& u) {
          if (first) skippedFirst[static_cast<size_t>(r)] = u.skipped;
          first = false;
        });
    updates[static_cast<size_t>(r)] = learner.updates();
    nonFinite[static_cast<size_t>(r)] = learner.nonFiniteTotal();
    ends[static_cast<size_t>(r)] = snapshot(*policy);
    EXPECT_GT(distance(ends[static_cast<size_t>(r)], before), 0.0);
  });
  expectNoErrors(errors);
  for (int r = 0; r < 2; ++r) {
    // 3 updates on both ranks (rank 1 repeats its first batch), one skipped
    EXPECT_EQ(epochs[static_cast<size_t>(r)].updates, 2) << "rank " << r;
    EXPECT_EQ(epochs[static_cast<size_t>(r)].skipped, 1) << "rank " << r;
    EXPECT_TRUE(skippedFirst[static_cast<size_t>(r)]);
    EXPECT_EQ(updates[static_cast<size_t>(r)], 2);
    EXPECT_EQ(nonFinite[static_cast<size_t>(r)], 1);
  }
  for (size_t i = 0; i < ends[0].size(); ++i)
    EXPECT_TRUE(torch::equal(ends[0][i], ends[1][i])) << "parameter " << i;
}

}  // namespace
}  // namespace vln::train
