#pragma once
// An HttpServer on 127.0.0.1 (a free port) with its io_context on a thread
// of its own, and a sample router: what the server tests talk to.

#include <gtest/gtest.h>

#include <asio/executor_work_guard.hpp>
#include <asio/io_context.hpp>
#include <chrono>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <thread>

#include "http/http_server.hpp"
#include "http_test_client.hpp"

namespace lec6::serve::testing {

// /hello: GET → {"hello":"world"}; POST echoes the body; other methods 405.
// Everything else: 404.
inline void sample_router(HttpRequest req, Responder res) {
  if (req.path == "/hello") {
    if (req.method == "GET" || req.method == "HEAD") {
      res.respond(json_response(200, {{"hello", "world"}}));
    } else if (req.method == "POST") {
      res.respond(json_response(200, {{"got", req.body}, {"peer_loopback", req.loopback_peer}}));
    } else {
      auto r = error_response(405, req.method + " is not allowed on /hello");
      r.headers.set("Allow", "GET, HEAD, POST");
      res.respond(std::move(r));
    }
    return;
  }
  res.respond(error_response(404, "no such endpoint: " + req.path));
}

class ServerFixture : public ::testing::Test {
 protected:
  void start(Router router, HttpServerOptions options = {}) {
    options.log = [this](std::string line) {
      std::lock_guard lock(log_mutex_);
      log_.push_back(std::move(line));
    };
    ListenerConfig listener;  // 127.0.0.1, port 0: a free one
    server_ = std::make_unique<HttpServer>(io_, listener, std::move(router), options);
    thread_ = std::thread([this] { io_.run(); });
  }

  void TearDown() override {
    if (server_) server_->stop();
    guard_.reset();
    io_.stop();
    if (thread_.joinable()) thread_.join();
    server_.reset();
  }

  uint16_t port() const { return server_->port(); }

  // Polls `done` until it holds or 10 s pass (a wait on an event with a deadline).
  static bool eventually(const std::function<bool()>& done,
                         std::chrono::milliseconds within = std::chrono::seconds(10)) {
    const auto end = std::chrono::steady_clock::now() + within;
    while (!done()) {
      if (std::chrono::steady_clock::now() > end) return false;
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    return true;
  }

  asio::io_context io_;
  asio::executor_work_guard<asio::io_context::executor_type> guard_ = asio::make_work_guard(io_);
  std::unique_ptr<HttpServer> server_;
  std::thread thread_;
  std::mutex log_mutex_;
  std::vector<std::string> log_;
};

}  // namespace lec6::serve::testing
