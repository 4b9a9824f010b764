#pragma once
// A blocking HTTP/1.1 client on a plain POSIX socket, for the server tests:
// it sends what a test writes, byte for byte, and reads with a deadline (no
// test waits forever, none sleeps to synchronise).

#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdint>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>

namespace lec6::serve::testing {

using namespace std::chrono_literals;

struct Reply {
  int status = 0;
  std::map<std::string, std::string> headers;  // names in lower case
  std::string body;
  std::string header(const std::string& lower_name) const {
    auto it = headers.find(lower_name);
    return it == headers.end() ? std::string() : it->second;
  }
};

class TestClient {
 public:
  // Connects to 127.0.0.1:port; throws when the connection is refused.
  explicit TestClient(uint16_t port) {
    fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(port);
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (::connect(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
      ::close(fd_);
      fd_ = -1;
      throw std::runtime_error("connect failed");
    }
    int one = 1;
    ::setsockopt(fd_, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  }
  ~TestClient() { close(); }
  TestClient(const TestClient&) = delete;
  TestClient& operator=(const TestClient&) = delete;

  static bool can_connect(uint16_t port) {
    try {
      TestClient c(port);
      return true;
    } catch (const std::exception&) {
      return false;
    }
  }

  void send(std::string_view bytes) {
    while (!bytes.empty()) {
      const ssize_t n = ::send(fd_, bytes.data(), bytes.size(), MSG_NOSIGNAL);
      if (n <= 0) throw std::runtime_error("send failed");
      bytes.remove_prefix(static_cast<std::size_t>(n));
    }
  }

  void close() {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }

  // Reads more into buffer(); false on timeout, EOF or error (closed() tells).
  bool read_more(std::chrono::milliseconds within = 10s) {
    if (closed_) return false;
    pollfd p{fd_, POLLIN, 0};
    if (::poll(&p, 1, static_cast<int>(within.count())) <= 0) return false;
    char chunk[65536];
    const ssize_t n = ::recv(fd_, chunk, sizeof chunk, 0);
    if (n <= 0) {
      closed_ = true;
      return false;
    }
    buffer_.append(chunk, static_cast<std::size_t>(n));
    return true;
  }

  // Reads until `needle` is in buffer(); false when the deadline passes first.
  bool read_until(std::string_view needle, std::chrono::milliseconds within = 10s) {
    const auto end = std::chrono::steady_clock::now() + within;
    while (buffer_.find(needle) == std::string::npos) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
          end - std::chrono::steady_clock::now());
      if (left <= 0ms || !read_more(left)) return buffer_.find(needle) != std::string::npos;
    }
    return true;
  }

  // Waits for the server to close; false if it is still open at the deadline.
  bool wait_closed(std::chrono::milliseconds within = 10s) {
    const auto end = std::chrono::steady_clock::now() + within;
    while (!closed_) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
          end - std::chrono::steady_clock::now());
      if (left <= 0ms) return false;
      read_more(left);
    }
    return true;
  }

  // One response from the buffer and the socket; nullopt on timeout or a
  // connection closed before a whole response came.
  std::optional<Reply> read_response(bool head = false, std::chrono::milliseconds within = 10s) {
    if (!read_until("\r\n\r\n", within)) return std::nullopt;
    const auto end_of_head = buffer_.find("\r\n\r\n");
    Reply r;
    const std::string head_text = buffer_.substr(0, end_of_head);
    r.status = std::stoi(head_text.substr(9, 3));
    std::size_t at = head_text.find("\r\n");
    while (at != std::string::npos && at < head_text.size()) {
      const auto next = head_text.find("\r\n", at + 2);
      const std::string line = head_text.substr(at + 2, next - at - 2);
      const auto colon = line.find(':');
      std::string name = line.substr(0, colon);
      for (char& c : name) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
      std::string value = colon == std::string::npos ? "" : line.substr(colon + 1);
      while (!value.empty() && value.front() == ' ') value.erase(0, 1);
      r.headers[name] = value;
      at = next;
    }
    buffer_.erase(0, end_of_head + 4);
    std::size_t length = 0;
    if (auto cl = r.headers.find("content-length"); cl != r.headers.end() && !head)
      length = std::stoul(cl->second);
    while (buffer_.size() < length) {
      if (!read_more(within)) return std::nullopt;
    }
    r.body = buffer_.substr(0, length);
    buffer_.erase(0, length);
    return r;
  }

  std::string& buffer() { return buffer_; }
  bool closed() const { return closed_; }

 private:
  int fd_ = -1;
  bool closed_ = false;
  std::string buffer_;
};

inline std::string get(std::string_view path, std::string_view extra = "") {
  return "GET " + std::string(path) + " HTTP/1.1\r\nHost: 127.0.0.1\r\n" + std::string(extra) +
         "\r\n";
}

}  // namespace lec6::serve::testing
