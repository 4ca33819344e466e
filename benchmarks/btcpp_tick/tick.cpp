// BehaviorTree.CPP's tick on a tree from XML, for benchmarks/bench_btcpp.py (not shipped).
//
// Usage: btcpp_tick FILE.xml TICKS [WARMUP]
//
// Builds the tree with BT.CPP's own factory, ticks it WARMUP times untimed, then
// TICKS times with Tree::tickExactlyOnce() (BT.CPP's plain tick: no sleep, no
// second tick on a wake-up signal) on the steady clock. Prints three lines:
//
//   nodes N              every node of the tree, as BT.CPP built it
//   status S             the root's status after the last tick
//   seconds_per_tick X   the timed ticks' wall time over TICKS
//
// The benchmark trees use BT.CPP's built-in nodes (Sequence, ReactiveSequence,
// Fallback, ReactiveFallback, Parallel, Timeout, AlwaysSuccess, AlwaysFailure)
// and two leaves BT.CPP has no built-in for, defined here the way a BT.CPP user
// writes them (StatefulActionNode, as the py_trees leaves they stand for):
//
//   running   pirate_bt's `running` node (py_trees' Running): RUNNING on every tick;
//   Step      bench_trace.py's Step: runs for `ticks` ticks, then SUCCESS, with a
//             progress text every 10 ticks, as the Python leaf keeps one.
#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>

#include "behaviortree_cpp/bt_factory.h"

namespace
{

class Running : public BT::StatefulActionNode
{
public:
  Running(const std::string& name, const BT::NodeConfig& config)
    : BT::StatefulActionNode(name, config)
  {}
  static BT::PortsList providedPorts()
  {
    return {};
  }
  BT::NodeStatus onStart() override
  {
    return BT::NodeStatus::RUNNING;
  }
  BT::NodeStatus onRunning() override
  {
    return BT::NodeStatus::RUNNING;
  }
  void onHalted() override
  {}
};

class Step : public BT::StatefulActionNode
{
public:
  Step(const std::string& name, const BT::NodeConfig& config)
    : BT::StatefulActionNode(name, config)
  {}
  static BT::PortsList providedPorts()
  {
    return { BT::InputPort<uint64_t>("ticks", "ticks to run before SUCCESS") };
  }
  BT::NodeStatus onStart() override
  {
    if(!getInput("ticks", ticks_))
    {
      throw BT::RuntimeError("Step: missing port [ticks]");
    }
    count_ = 0;
    return onRunning();
  }
  BT::NodeStatus onRunning() override
  {
    ++count_;
    if(count_ % 10 == 0)
    {
      feedback_ = std::to_string(count_) + "/" + std::to_string(ticks_);
    }
    return count_ >= ticks_ ? BT::NodeStatus::SUCCESS : BT::NodeStatus::RUNNING;
  }
  void onHalted() override
  {}

private:
  uint64_t ticks_ = 0;
  uint64_t count_ = 0;
  std::string feedback_;
};

}  // namespace

int main(int argc, char** argv)
{
  if(argc != 3 && argc != 4)
  {
    std::cerr << "usage: btcpp_tick FILE.xml TICKS [WARMUP]\n";
    return 2;
  }
  std::ifstream stream(argv[1]);
  if(!stream)
  {
    std::cerr << "error: cannot read " << argv[1] << "\n";
    return 2;
  }
  std::stringstream buffer;
  buffer << stream.rdbuf();
  const long ticks = std::strtol(argv[2], nullptr, 10);
  const long warmup = argc == 4 ? std::strtol(argv[3], nullptr, 10) : 0;
  if(ticks <= 0 || warmup < 0)
  {
    std::cerr << "error: TICKS must be > 0 and WARMUP >= 0\n";
    return 2;
  }
  try
  {
    BT::BehaviorTreeFactory factory;
    factory.registerNodeType<Running>("running");
    factory.registerNodeType<Step>("Step");
    auto tree = factory.createTreeFromText(buffer.str());
    long nodes = 0;
    BT::applyRecursiveVisitor(tree.rootNode(), [&nodes](BT::TreeNode*) { nodes++; });

    BT::NodeStatus status = BT::NodeStatus::IDLE;
    for(long i = 0; i < warmup; i++)
    {
      status = tree.tickExactlyOnce();
    }
    const auto start = std::chrono::steady_clock::now();
    for(long i = 0; i < ticks; i++)
    {
      status = tree.tickExactlyOnce();
    }
    const std::chrono::duration<double> took = std::chrono::steady_clock::now() - start;
    std::cout << "nodes " << nodes << "\n"
              << "status " << BT::toStr(status) << "\n"
              << "seconds_per_tick " << took.count() / static_cast<double>(ticks) << "\n";
  }
  catch(const std::exception& ex)
  {
    std::cerr << "error: " << ex.what() << "\n";
    return 1;
  }
  return 0;
}
