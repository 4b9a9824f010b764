// The HTTP listener: bind, accept, cap the connections, stop.

#include "http/http_server.hpp"

#include <fmt/format.h>

#include <asio/io_context.hpp>
#include <asio/ip/tcp.hpp>
#include <asio/post.hpp>
#include <asio/steady_timer.hpp>
#include <asio/strand.hpp>
#include <stdexcept>
#include <vector>

#include "http/http_connection.hpp"

namespace lec6::serve {

using detail::Connection;

struct HttpServer::Core : std::enable_shared_from_this<Core> {
  Core(asio::io_context& io, std::shared_ptr<detail::ServerShared> s)
      : io(io),
        acceptor(asio::make_strand(io)),
        retry(acceptor.get_executor()),
        shared(std::move(s)) {}

  void accept() {
    acceptor.async_accept(
        asio::make_strand(io),
        [self = shared_from_this()](const std::error_code& ec, asio::ip::tcp::socket socket) {
          self->accepted(ec, std::move(socket));
        });
  }

  void accepted(const std::error_code& ec, asio::ip::tcp::socket socket) {
    if (ec == asio::error::operation_aborted || !acceptor.is_open()) return;
    if (ec) {
      // Out of file descriptors and the like: try again shortly, not in a spin.
      shared->log(fmt::format("HTTP on {}: accept failed: {}", address, ec.message()));
      retry.expires_after(std::chrono::milliseconds(100));
      retry.async_wait([self = shared_from_this()](const std::error_code& e) {
        if (!e) self->accept();
      });
      return;
    }
    auto conn = std::make_shared<Connection>(std::move(socket), shared);
    bool refuse = false;
    {
      std::lock_guard lock(shared->mutex);
      if (shared->stopping) return;  // the socket closes with `conn`
      refuse = shared->counted >= shared->options.max_connections;
      conn->set_counted(!refuse);
      if (!refuse) ++shared->counted;
      shared->connections.emplace(conn.get(), conn);
    }
    std::optional<HttpResponse> refusal;
    if (refuse) {
      refusal = error_response(
          503, fmt::format("too many connections (at most {}): close some browser tabs or clients",
                           shared->options.max_connections));
      refusal->headers.set("Retry-After", "1");
    }
    asio::post(conn->executor(),
               [conn, refusal = std::move(refusal)]() mutable { conn->start(std::move(refusal)); });
    accept();
  }

  asio::io_context& io;
  asio::ip::tcp::acceptor acceptor;
  asio::steady_timer retry;
  std::shared_ptr<detail::ServerShared> shared;
  uint16_t port = 0;
  std::string address;
};

HttpServer::HttpServer(asio::io_context& io, const ListenerConfig& config, Router router,
                       HttpServerOptions options) {
  auto shared = std::make_shared<detail::ServerShared>();
  shared->router = std::move(router);
  shared->options = std::move(options);
  core_ = std::make_shared<Core>(io, shared);

  const std::string wanted = config.listen.text();
  auto fail = [&](const std::string& why) {
    throw std::runtime_error(fmt::format("cannot listen for HTTP on {}: {}", wanted, why));
  };
  std::error_code ec;
  asio::ip::tcp::resolver resolver(io);
  const auto found = resolver.resolve(
      config.listen.address, std::to_string(config.listen.port),
      asio::ip::resolver_base::passive | asio::ip::resolver_base::numeric_service, ec);
  if (ec || found.empty()) fail(ec ? ec.message() : "the address does not resolve");
  const asio::ip::tcp::endpoint endpoint = found.begin()->endpoint();
  auto& acceptor = core_->acceptor;
  if (acceptor.open(endpoint.protocol(), ec)) fail(ec.message());
  acceptor.set_option(asio::socket_base::reuse_address(true), ec);
  if (acceptor.bind(endpoint, ec)) fail(ec.message());
  if (acceptor.listen(asio::socket_base::max_listen_connections, ec)) fail(ec.message());
  const auto bound = acceptor.local_endpoint(ec);
  core_->port = bound.port();
  core_->address = bound.address().is_v6()
                       ? fmt::format("[{}]:{}", bound.address().to_string(), bound.port())
                       : fmt::format("{}:{}", bound.address().to_string(), bound.port());

  if (!config.listen.loopback()) {
    shared->log(fmt::format(
        "warning: HTTP on {} is reachable from other machines{}", core_->address,
        config.read_only ? " (read-only)" : "; writes need the token (Authorization: Bearer)"));
  }
  asio::post(acceptor.get_executor(), [core = core_] { core->accept(); });
}

HttpServer::~HttpServer() {
  stop();
}

uint16_t HttpServer::port() const {
  return core_->port;
}

std::string HttpServer::address() const {
  return core_->address;
}

void HttpServer::stop() {
  asio::post(core_->acceptor.get_executor(), [core = core_] {
    std::error_code ec;
    core->acceptor.close(ec);
    core->retry.cancel();
  });
  std::vector<std::weak_ptr<Connection>> open;
  {
    std::lock_guard lock(core_->shared->mutex);
    core_->shared->stopping = true;
    for (const auto& [_, c] : core_->shared->connections) open.push_back(c);
  }
  for (auto& w : open) {
    if (auto c = w.lock()) c->stop();
  }
}

std::size_t HttpServer::connections() const {
  std::lock_guard lock(core_->shared->mutex);
  return core_->shared->counted;
}

}  // namespace lec6::serve
