// A Groot2 client on BehaviorTree.CPP's own protocol header (groot2_protocol.h) and
// cppzmq, as Groot2 itself talks to a Groot2Publisher. A test tool, not shipped.
//
// Usage: groot2_client
//
// Reads commands on stdin, one a line, and answers one JSON line each on stdout:
//
//   connect NAME HOST PORT        a REQ socket to PORT and a SUB socket to PORT + 1
//   ask NAME TYPE [TEXT]          one request of TYPE (one letter: T S B I R U D A X r t),
//                                 with TEXT as its second part when given
//   raw NAME HEX [HEX...]         send these parts as they are (malformed requests)
//   notice NAME MS                wait up to MS for a breakpoint notice on SUB
//   quit
//
// A reply is reported as {"parts": N, "error": ...} for an error reply, else with
// the reply header checked against the request by BT.CPP's own operator== and
// the payload decoded as BT.CPP's code would: the XML text, the status buffer as
// [uid, status] pairs (Monitor::Deserialize), the blackboard MessagePack as JSON
// (nlohmann::json::from_msgpack), the transitions as [time_us, uid, status].
#include <cstdint>
#include <iostream>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "behaviortree_cpp/contrib/json.hpp"
#include "behaviortree_cpp/loggers/groot2_protocol.h"
#include "zmq.hpp"
#include "zmq_addon.hpp"

using nlohmann::json;
namespace Monitor = BT::Monitor;

namespace
{

struct Connection
{
  std::unique_ptr<zmq::socket_t> req;
  std::unique_ptr<zmq::socket_t> sub;
};

std::string hex(const std::string& bytes)
{
  static const char* digits = "0123456789abcdef";
  std::string out;
  for(unsigned char c : bytes)
  {
    out += digits[c >> 4];
    out += digits[c & 15];
  }
  return out;
}

std::string unhex(const std::string& text)
{
  std::string out;
  for(size_t i = 0; i + 1 < text.size(); i += 2)
  {
    out += static_cast<char>(std::stoi(text.substr(i, 2), nullptr, 16));
  }
  return out;
}

json decode(Monitor::RequestType type, const std::string& body)
{
  switch(type)
  {
    case Monitor::FULLTREE:
    case Monitor::HOOKS_DUMP:
      return body;
    case Monitor::STATUS: {
      json pairs = json::array();
      for(unsigned offset = 0; offset + 3 <= body.size(); offset += 3)
      {
        uint16_t uid = 0;
        uint8_t status = 0;
        Monitor::Deserialize(body.data(), offset, uid);
        Monitor::Deserialize(body.data(), offset + 2, status);
        pairs.push_back({ uid, status });
      }
      return pairs;
    }
    case Monitor::BLACKBOARD:
      return json::from_msgpack(body);
    case Monitor::GET_TRANSITIONS: {
      json out = json::array();
      for(size_t offset = 0; offset + 9 <= body.size(); offset += 9)
      {
        uint64_t time_us = 0;
        std::memcpy(&time_us, body.data() + offset, 6);
        uint16_t uid = 0;
        std::memcpy(&uid, body.data() + offset + 6, 2);
        out.push_back({ time_us, uid, static_cast<uint8_t>(body[offset + 8]) });
      }
      return out;
    }
    default:
      return hex(body);
  }
}

json report(const Monitor::RequestHeader& request, zmq::multipart_t& reply)
{
  json out;
  out["parts"] = reply.size();
  if(reply.size() == 2 && reply[0].to_string() == "error")
  {
    out["error"] = reply[1].to_string();
    return out;
  }
  const std::string head = reply[0].to_string();
  if(head.size() != Monitor::ReplyHeader::size())
  {
    out["bad_header"] = hex(head);
    return out;
  }
  const auto header = Monitor::DeserializeReplyHeader(head);
  out["matches"] = (header.request == request);
  out["protocol"] = header.request.protocol;
  out["uuid"] = hex(std::string(header.tree_id.data(), header.tree_id.size()));
  json body = json::array();
  for(size_t i = 1; i < reply.size(); i++)
  {
    body.push_back(decode(request.type, reply[i].to_string()));
  }
  out["body"] = body;
  return out;
}

}  // namespace

int main()
{
  zmq::context_t context;
  std::map<std::string, Connection> connections;
  std::string line;
  while(std::getline(std::cin, line))
  {
    std::istringstream words(line);
    std::string command, name;
    words >> command >> name;
    json out;
    try
    {
      if(command == "quit")
      {
        break;
      }
      if(command == "connect")
      {
        std::string host;
        unsigned port = 0;
        words >> host >> port;
        Connection connection;
        connection.req = std::make_unique<zmq::socket_t>(context, ZMQ_REQ);
        connection.req->set(zmq::sockopt::linger, 0);
        connection.req->set(zmq::sockopt::rcvtimeo, 5000);
        connection.req->connect("tcp://" + host + ":" + std::to_string(port));
        connection.sub = std::make_unique<zmq::socket_t>(context, ZMQ_SUB);
        connection.sub->set(zmq::sockopt::linger, 0);
        connection.sub->set(zmq::sockopt::subscribe, "");
        connection.sub->connect("tcp://" + host + ":" + std::to_string(port + 1));
        connections[name] = std::move(connection);
        out["ok"] = true;
      }
      else if(command == "ask" || command == "raw")
      {
        auto& connection = connections.at(name);
        zmq::multipart_t request;
        Monitor::RequestHeader header;
        if(command == "ask")
        {
          std::string type;
          words >> type;
          header = Monitor::RequestHeader(static_cast<Monitor::RequestType>(type.at(0)));
          request.addstr(Monitor::SerializeHeader(header));
          std::string rest;
          std::getline(words, rest);
          if(!rest.empty())
          {
            request.addstr(rest.substr(1));  // after the one space
          }
        }
        else
        {
          std::string part;
          while(words >> part)
          {
            request.addstr(unhex(part == "-" ? "" : part));
          }
          header.type = Monitor::UNDEFINED;
        }
        request.send(*connection.req);
        zmq::multipart_t reply;
        if(!reply.recv(*connection.req))
        {
          out["timeout"] = true;
        }
        else
        {
          out = report(header, reply);
        }
      }
      else if(command == "notice")
      {
        int ms = 0;
        words >> ms;
        auto& connection = connections.at(name);
        connection.sub->set(zmq::sockopt::rcvtimeo, ms);
        zmq::multipart_t notice;
        if(!notice.recv(*connection.sub))
        {
          out["timeout"] = true;
        }
        else
        {
          const auto header = Monitor::DeserializeRequestHeader(notice[0].to_string());
          out["type"] = std::string(1, static_cast<char>(header.type));
          out["protocol"] = header.protocol;
          out["uid"] = notice.size() > 1 ? notice[1].to_string() : "";
        }
      }
      else
      {
        out["unknown"] = command;
      }
    }
    catch(const std::exception& ex)
    {
      out["exception"] = ex.what();
    }
    std::cout << out.dump() << std::endl;
  }
  return 0;
}
