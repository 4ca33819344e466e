// The reference Groot2 server: BehaviorTree.CPP's own Groot2Publisher (and its
// TreeObserver) on a tree loaded from pirate_bt's exported XML. A test tool, not shipped.
//
// Usage: groot2_reference FILE.xml PORT
//
// Registers every node type of the file's <TreeNodesModel> with its ports, as in
// tests/btcpp_checker/checker.cpp: leaves return the status the test scripted for
// them this tick, decorators of pirate_bt's own pass their child's status on
// (turning RUNNING first and resetting a finished child, as BT.CPP's decorators
// do). BT.CPP's own nodes (Sequence, ReactiveFallback, Inverter, SubTree...) are
// BT.CPP's. Then it serves the tree with BT::Groot2Publisher on PORT and PORT + 1
// and reads commands on stdin, one a line, answering one line each on stdout:
//
//   status UID CODE   the leaf UID returns CODE (1 running, 2 success, 3 failure)
//                     when next ticked (scripts last one tick)  -> "ok"
//   tick              start one tick (tickExactlyOnce) on a worker thread -> "ok"
//   wait              wait for it -> "done ROOT_RESULT UNSCRIPTED_UIDS..." (leaves ticked
//                     without a script, which then failed)
//   stats             TreeObserver's statistics -> "stats UID:TRANS:OK:FAIL:SKIP ..."
//   quit              -> "bye"
#include <atomic>
#include <condition_variable>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <map>
#include <mutex>
#include <set>
#include <sstream>
#include <string>
#include <thread>

#include "behaviortree_cpp/bt_factory.h"
#include "behaviortree_cpp/loggers/bt_observer.h"
#include "behaviortree_cpp/loggers/groot2_publisher.h"
#include "tinyxml2.h"

namespace
{

std::mutex script_mutex;
std::map<uint16_t, BT::NodeStatus> script;
std::set<uint16_t> unscripted;

BT::NodeStatus scripted(const BT::TreeNode& node)
{
  std::lock_guard<std::mutex> lock(script_mutex);
  auto found = script.find(node.UID());
  if(found == script.end())
  {
    unscripted.insert(node.UID());
    return BT::NodeStatus::FAILURE;
  }
  return found->second;
}

class ScriptedAction : public BT::ActionNodeBase
{
public:
  ScriptedAction(const std::string& name, const BT::NodeConfig& config)
    : BT::ActionNodeBase(name, config)
  {}
  BT::NodeStatus tick() override
  {
    return scripted(*this);
  }
  void halt() override
  {
    resetStatus();
  }
};

class ScriptedCondition : public BT::ConditionNode
{
public:
  ScriptedCondition(const std::string& name, const BT::NodeConfig& config)
    : BT::ConditionNode(name, config)
  {}
  BT::NodeStatus tick() override
  {
    return scripted(*this);
  }
};

class PassDecorator : public BT::DecoratorNode
{
public:
  PassDecorator(const std::string& name, const BT::NodeConfig& config)
    : BT::DecoratorNode(name, config)
  {}
  BT::NodeStatus tick() override
  {
    setStatus(BT::NodeStatus::RUNNING);
    const BT::NodeStatus status = child()->executeTick();
    if(BT::isStatusCompleted(status))
    {
      resetChild();
    }
    return status;
  }
};

class FirstChildControl : public BT::ControlNode
{
public:
  FirstChildControl(const std::string& name, const BT::NodeConfig& config)
    : BT::ControlNode(name, config)
  {}
  BT::NodeStatus tick() override
  {
    setStatus(BT::NodeStatus::RUNNING);
    const BT::NodeStatus status = children_nodes_.front()->executeTick();
    if(BT::isStatusCompleted(status))
    {
      resetChildren();
    }
    return status;
  }
};

std::pair<std::string, BT::PortInfo> makePort(const char* name, const char* type)
{
  const std::string kind = type ? type : "string";
  if(kind == "integer")
  {
    return BT::InputPort<int>(name);
  }
  if(kind == "number")
  {
    return BT::InputPort<double>(name);
  }
  if(kind == "boolean")
  {
    return BT::InputPort<bool>(name);
  }
  return BT::InputPort<std::string>(name);
}

template <typename Node>
BT::NodeBuilder builderOf()
{
  return [](const std::string& name, const BT::NodeConfig& config) {
    return std::make_unique<Node>(name, config);
  };
}

int registerModels(BT::BehaviorTreeFactory& factory, const std::string& xml)
{
  tinyxml2::XMLDocument doc;
  if(doc.Parse(xml.c_str(), xml.size()) != tinyxml2::XML_SUCCESS)
  {
    throw std::runtime_error(doc.ErrorStr());
  }
  const auto* root = doc.RootElement();
  const auto* models = root ? root->FirstChildElement("TreeNodesModel") : nullptr;
  int registered = 0;
  for(auto* model = models ? models->FirstChildElement() : nullptr; model;
      model = model->NextSiblingElement())
  {
    const std::string tag = model->Name();
    const char* id = model->Attribute("ID");
    if(tag == "SubTree" || !id || factory.builtinNodes().count(id))
    {
      continue;
    }
    BT::TreeNodeManifest manifest;
    manifest.registration_ID = id;
    BT::NodeBuilder builder;
    if(tag == "Action")
    {
      manifest.type = BT::NodeType::ACTION;
      builder = builderOf<ScriptedAction>();
    }
    else if(tag == "Condition")
    {
      manifest.type = BT::NodeType::CONDITION;
      builder = builderOf<ScriptedCondition>();
    }
    else if(tag == "Decorator")
    {
      manifest.type = BT::NodeType::DECORATOR;
      builder = builderOf<PassDecorator>();
    }
    else
    {
      manifest.type = BT::NodeType::CONTROL;
      builder = builderOf<FirstChildControl>();
    }
    for(auto* port = model->FirstChildElement("input_port"); port;
        port = port->NextSiblingElement("input_port"))
    {
      manifest.ports.insert(makePort(port->Attribute("name"), port->Attribute("type")));
    }
    factory.registerBuilder(manifest, builder);
    registered++;
  }
  return registered;
}

}  // namespace

int main(int argc, char** argv)
{
  if(argc != 3)
  {
    std::cerr << "usage: groot2_reference FILE.xml PORT\n";
    return 2;
  }
  std::ifstream stream(argv[1]);
  std::stringstream buffer;
  buffer << stream.rdbuf();
  const std::string xml = buffer.str();
  const unsigned port = static_cast<unsigned>(std::stoul(argv[2]));

  BT::BehaviorTreeFactory factory;
  try
  {
    registerModels(factory, xml);
    auto tree = factory.createTreeFromText(xml);
    BT::TreeObserver observer(tree);
    BT::Groot2Publisher publisher(tree, port);

    std::thread worker;
    std::atomic<int> result{ 0 };
    std::string line;
    std::cout << "ready" << std::endl;
    while(std::getline(std::cin, line))
    {
      std::istringstream words(line);
      std::string command;
      words >> command;
      if(command == "status")
      {
        unsigned uid = 0;
        int code = 0;
        words >> uid >> code;
        std::lock_guard<std::mutex> lock(script_mutex);
        script[static_cast<uint16_t>(uid)] = static_cast<BT::NodeStatus>(code);
        std::cout << "ok" << std::endl;
      }
      else if(command == "tick")
      {
        worker = std::thread(
            [&tree, &result]() { result = static_cast<int>(tree.tickExactlyOnce()); });
        std::cout << "ok" << std::endl;
      }
      else if(command == "wait")
      {
        if(worker.joinable())
        {
          worker.join();
        }
        std::lock_guard<std::mutex> lock(script_mutex);
        std::cout << "done " << result.load();
        for(auto uid : unscripted)
        {
          std::cout << " " << uid;
        }
        std::cout << std::endl;
        script.clear();
        unscripted.clear();
      }
      else if(command == "stats")
      {
        std::cout << "stats";
        for(const auto& [uid, stats] : observer.statistics())
        {
          std::cout << " " << uid << ":" << stats.transitions_count << ":"
                    << stats.success_count << ":" << stats.failure_count << ":"
                    << stats.skip_count;
        }
        std::cout << std::endl;
      }
      else if(command == "quit")
      {
        if(worker.joinable())
        {
          worker.join();
        }
        std::cout << "bye" << std::endl;
        return 0;
      }
      else
      {
        std::cout << "unknown " << command << std::endl;
      }
    }
    if(worker.joinable())
    {
      worker.join();
    }
  }
  catch(const std::exception& ex)
  {
    std::cout << "error: " << ex.what() << std::endl;
    return 1;
  }
  return 0;
}
