// SSE stream queues and the Responder / EventStream handles.

#include "http/http_stream_state.hpp"

#include <algorithm>

namespace lec6::serve {
namespace detail {

StreamState::StreamState(std::size_t limit) : limit_(std::max<std::size_t>(limit, 1)) {}

void StreamState::set_wake(std::function<void()> wake) {
  std::lock_guard lock(mutex_);
  wake_ = std::move(wake);
}

void StreamState::wake() {
  std::function<void()> w;
  {
    std::lock_guard lock(mutex_);
    if (wake_pending_ || !wake_) return;
    wake_pending_ = true;
    w = wake_;
  }
  w();
}

bool StreamState::push(std::string bytes, bool droppable) {
  bool overflow = false;
  {
    std::lock_guard lock(mutex_);
    if (closed_) return false;
    queue_.push_back({std::move(bytes), droppable});
    // Over the bound: the oldest droppable event goes.
    if (queue_.size() > limit_) {
      auto oldest =
          std::find_if(queue_.begin(), queue_.end(), [](const Item& i) { return i.droppable; });
      if (oldest != queue_.end()) {
        queue_.erase(oldest);
        ++dropped_;
      }
    }
    overflow = queue_.size() > 4 * limit_;
  }
  if (overflow) {
    // Only reliable events left and still too many: the browser is hopelessly
    // behind. Its EventSource reconnects and starts from a fresh snapshot.
    close();
    return false;
  }
  wake();
  return true;
}

std::string StreamState::drain() {
  std::lock_guard lock(mutex_);
  wake_pending_ = false;
  std::string out;
  for (auto& i : queue_) out += i.bytes;
  queue_.clear();
  return out;
}

bool StreamState::empty() const {
  std::lock_guard lock(mutex_);
  return queue_.empty();
}

bool StreamState::close() {
  std::function<void()> w;
  {
    std::lock_guard lock(mutex_);
    if (closed_) return false;
    closed_ = true;
    w = wake_;
  }
  if (w) {
    w();  // even with a wake pending: the connection must see the close
  } else {
    run_close_callbacks();  // no connection behind it (detached, or never opened)
  }
  return true;
}

bool StreamState::closed() const {
  std::lock_guard lock(mutex_);
  return closed_;
}

void StreamState::on_close(std::function<void()> callback) {
  {
    std::lock_guard lock(mutex_);
    if (!callbacks_ran_) {
      callbacks_.push_back(std::move(callback));
      return;
    }
  }
  callback();
}

void StreamState::run_close_callbacks() {
  std::vector<std::function<void()>> callbacks;
  {
    std::lock_guard lock(mutex_);
    if (callbacks_ran_) return;
    callbacks_ran_ = true;
    callbacks.swap(callbacks_);
  }
  for (auto& c : callbacks) c();
}

std::size_t StreamState::dropped() const {
  std::lock_guard lock(mutex_);
  return dropped_;
}

namespace {

// Responder::capture: the answer goes to a function, streams are closed.
class CaptureExchange final : public Exchange {
 public:
  explicit CaptureExchange(std::function<void(HttpResponse)> sink) : sink_(std::move(sink)) {}
  bool respond(HttpResponse response) override {
    if (!claim()) return false;
    if (sink_) sink_(std::move(response));
    return true;
  }
  EventStream open_stream() override {
    claim();
    return EventStream();
  }
  static Responder make(std::function<void(HttpResponse)> sink) {
    return responder_of(std::make_shared<CaptureExchange>(std::move(sink)));
  }

 private:
  std::function<void(HttpResponse)> sink_;
};

}  // namespace
}  // namespace detail

bool EventStream::send(std::string_view event, std::string_view data, Delivery delivery,
                       std::optional<std::string_view> id) const {
  if (!state_) return false;
  return state_->push(encode_event(event, data, id), delivery == Delivery::Droppable);
}

bool EventStream::closed() const {
  return !state_ || state_->closed();
}

void EventStream::close() const {
  if (state_) state_->close();
}

void EventStream::on_close(std::function<void()> callback) const {
  if (state_) {
    state_->on_close(std::move(callback));
  } else if (callback) {
    callback();
  }
}

std::size_t EventStream::dropped() const {
  return state_ ? state_->dropped() : 0;
}

bool Responder::respond(HttpResponse response) const {
  return exchange_ && exchange_->respond(std::move(response));
}

EventStream Responder::open_stream() const {
  return exchange_ ? exchange_->open_stream() : EventStream();
}

bool Responder::answered() const {
  return !exchange_ || exchange_->answered();
}

Responder Responder::capture(std::function<void(HttpResponse)> sink) {
  return detail::CaptureExchange::make(std::move(sink));
}

}  // namespace lec6::serve
