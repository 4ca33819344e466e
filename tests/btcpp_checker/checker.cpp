// Port checker for pirate_bt's BehaviorTree.CPP export (a test tool, not shipped).
//
// Usage: btcpp_checker FILE.xml
//
// Registers every node type of the file's <TreeNodesModel> (Action, Condition,
// Decorator, Control) with BT.CPP, with the ports the model declares, as a dummy
// node; then lets BT.CPP create the main tree. BT.CPP itself then checks what the
// Python bindings cannot: every port written on a node is declared by its model,
// typed constants convert (int, double, bool), every <SubTree> remaps what its
// model requires. Prints "ok N" (N nodes) or the BT.CPP error, exit 0 or 1.
#include <cstdio>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>

#include "behaviortree_cpp/bt_factory.h"
#include "tinyxml2.h"

namespace
{

class DummyAction : public BT::SyncActionNode
{
public:
  DummyAction(const std::string& name, const BT::NodeConfig& config)
    : BT::SyncActionNode(name, config)
  {}
  BT::NodeStatus tick() override
  {
    return BT::NodeStatus::SUCCESS;
  }
};

class DummyCondition : public BT::ConditionNode
{
public:
  DummyCondition(const std::string& name, const BT::NodeConfig& config)
    : BT::ConditionNode(name, config)
  {}
  BT::NodeStatus tick() override
  {
    return BT::NodeStatus::SUCCESS;
  }
};

class DummyDecorator : public BT::DecoratorNode
{
public:
  DummyDecorator(const std::string& name, const BT::NodeConfig& config)
    : BT::DecoratorNode(name, config)
  {}
  BT::NodeStatus tick() override
  {
    return child()->executeTick();
  }
};

class DummyControl : public BT::ControlNode
{
public:
  DummyControl(const std::string& name, const BT::NodeConfig& config)
    : BT::ControlNode(name, config)
  {}
  BT::NodeStatus tick() override
  {
    return children_nodes_.front()->executeTick();
  }
};

// pirate_bt port type -> the C++ type BT.CPP converts constants to.
std::pair<std::string, BT::PortInfo> makePort(const char* name, const char* type,
                                              const char* description)
{
  const std::string kind = type ? type : "string";
  const char* text = description ? description : "";
  if(kind == "integer")
  {
    return BT::InputPort<int>(name, text);
  }
  if(kind == "number")
  {
    return BT::InputPort<double>(name, text);
  }
  if(kind == "boolean")
  {
    return BT::InputPort<bool>(name, text);
  }
  return BT::InputPort<std::string>(name, text);
}

template <typename Node>
BT::NodeBuilder builderOf()
{
  return [](const std::string& name, const BT::NodeConfig& config) {
    return std::make_unique<Node>(name, config);
  };
}

}  // namespace

int main(int argc, char** argv)
{
  if(argc != 2)
  {
    std::cerr << "usage: btcpp_checker FILE.xml\n";
    return 2;
  }
  std::ifstream stream(argv[1]);
  std::stringstream buffer;
  buffer << stream.rdbuf();
  const std::string xml = buffer.str();

  tinyxml2::XMLDocument doc;
  if(doc.Parse(xml.c_str(), xml.size()) != tinyxml2::XML_SUCCESS)
  {
    std::cout << "error: " << doc.ErrorStr() << "\n";
    return 1;
  }
  BT::BehaviorTreeFactory factory;
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
      builder = builderOf<DummyAction>();
    }
    else if(tag == "Condition")
    {
      manifest.type = BT::NodeType::CONDITION;
      builder = builderOf<DummyCondition>();
    }
    else if(tag == "Decorator")
    {
      manifest.type = BT::NodeType::DECORATOR;
      builder = builderOf<DummyDecorator>();
    }
    else if(tag == "Control")
    {
      manifest.type = BT::NodeType::CONTROL;
      builder = builderOf<DummyControl>();
    }
    else
    {
      std::cout << "error: unknown model tag <" << tag << ">\n";
      return 1;
    }
    for(auto* port = model->FirstChildElement("input_port"); port;
        port = port->NextSiblingElement("input_port"))
    {
      manifest.ports.insert(
          makePort(port->Attribute("name"), port->Attribute("type"), port->GetText()));
    }
    factory.registerBuilder(manifest, builder);
    registered++;
  }
  try
  {
    auto tree = factory.createTreeFromText(xml);
    int nodes = 0;
    tree.applyVisitor([&nodes](const BT::TreeNode*) { nodes++; });
    std::cout << "ok " << nodes << " nodes, " << registered << " node types\n";
  }
  catch(const std::exception& ex)
  {
    std::cout << "error: " << ex.what() << "\n";
    return 1;
  }
  return 0;
}
