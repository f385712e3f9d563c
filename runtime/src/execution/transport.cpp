// Per-world mailboxes: a deque under a mutex, a condition variable for
// blocking receives, a parked flag for task scheduling.
#include <chrono>
#include <thread>
#include "soda/runtime/transport.h"

#include <atomic>
#include <condition_variable>
#include <deque>
#include <mutex>
#include <string>
#include <variant>
#include <vector>

#include "soda/runtime/message_codec.h"
#include "execution/transport_bytes.h"

namespace soda {
namespace {

thread_local std::uint64_t t_bytes_sent = 0;  // thread_bytes_sent()

template <bool kSerialise>
class QueueTransport final : public Transport {
  using Item = std::conditional_t<kSerialise, std::vector<std::uint8_t>, Message>;

 public:
  explicit QueueTransport(int world_count) : boxes_(static_cast<std::size_t>(world_count)) {}

  void send(WorldId to, Message message) override {
    if (message.to != to) throw std::invalid_argument("Transport::send: message.to differs from the receiver");
    Box& box = box_of(to);
    Item item;
    if constexpr (kSerialise) {
      item = encode_message(message);
      bytes_.fetch_add(item.size(), std::memory_order_relaxed);
      t_bytes_sent += item.size();
    } else {
      item = std::move(message);
    }
    messages_.fetch_add(1, std::memory_order_relaxed);
    bool wake = false;
    {
      std::lock_guard lock(box.mutex);
      if (closed_.load()) return;
      box.queue.push_back(std::move(item));
      wake = box.parked;
      box.parked = false;
    }
    box.ready.notify_one();
    if (wake) hook_(to);
  }

  std::optional<Message> try_receive(WorldId world) override {
    Box& box = box_of(world);
    Item item;
    {
      std::lock_guard lock(box.mutex);
      if (box.queue.empty()) return std::nullopt;
      item = std::move(box.queue.front());
      box.queue.pop_front();
    }
    return unpack(std::move(item));
  }

  Message receive(WorldId world) override {
    Box& box = box_of(world);
    Item item;
    {
      std::unique_lock lock(box.mutex);
      box.ready.wait(lock, [&] { return !box.queue.empty() || closed_.load(); });
      if (box.queue.empty()) throw TransportClosed("transport closed while world " + std::to_string(world) + " waited");
      item = std::move(box.queue.front());
      box.queue.pop_front();
    }
    return unpack(std::move(item));
  }

  bool park(WorldId world) override {
    Box& box = box_of(world);
    std::lock_guard lock(box.mutex);
    if (closed_.load()) return true;  // parked for good: nothing will wake it
    if (!box.queue.empty()) return false;
    box.parked = true;
    return true;
  }

  void set_wake_hook(std::function<void(WorldId)> hook) override { hook_ = std::move(hook); }

  void close() override {
    closed_.store(true);
    for (Box& box : boxes_) {
      { std::lock_guard lock(box.mutex); }
      box.ready.notify_all();
    }
  }

  std::uint64_t messages_sent() const override { return messages_.load(); }
  std::uint64_t bytes_sent() const override { return bytes_.load(); }

 private:
  struct Box {
    std::mutex mutex;
    std::condition_variable ready;
    std::deque<Item> queue;
    bool parked = false;
  };

  Box& box_of(WorldId w) {
    if (w < 0 || static_cast<std::size_t>(w) >= boxes_.size())
      throw std::out_of_range("Transport: no world " + std::to_string(w));
    return boxes_[static_cast<std::size_t>(w)];
  }

  static Message unpack(Item item) {
    if constexpr (kSerialise) {
      return decode_message(item);
    } else {
      return item;
    }
  }

  std::vector<Box> boxes_;
  std::function<void(WorldId)> hook_ = [](WorldId) {};
  std::atomic<bool> closed_{false};
  std::atomic<std::uint64_t> messages_{0};
  std::atomic<std::uint64_t> bytes_{0};
};

}  // namespace

std::uint64_t thread_bytes_sent() { return t_bytes_sent; }

std::unique_ptr<Transport> make_in_memory_transport(int world_count) {
  return std::make_unique<QueueTransport<false>>(world_count);
}

std::unique_ptr<Transport> make_serialising_transport(int world_count) {
  return std::make_unique<QueueTransport<true>>(world_count);
}

}  // namespace soda

namespace soda {
namespace {

// Delays each send by a seeded random pause (in the sender, outside any
// lock), so that messages from different worlds arrive in orders a plain run
// rarely shows. Everything else is the inner transport's.
class FuzzingTransport final : public Transport {
 public:
  FuzzingTransport(std::unique_ptr<Transport> inner, std::uint64_t seed) : inner_(std::move(inner)), random_(seed) {}
  void send(WorldId to, Message message) override {
    fuzz_pause(random_);
    inner_->send(to, std::move(message));
  }
  // Delivery is delayed too: the receiver pauses before it takes a message.
  std::optional<Message> try_receive(WorldId world) override {
    std::optional<Message> m = inner_->try_receive(world);
    if (m) fuzz_pause(random_);
    return m;
  }
  Message receive(WorldId world) override {
    Message m = inner_->receive(world);
    fuzz_pause(random_);
    return m;
  }
  bool park(WorldId world) override { return inner_->park(world); }
  void set_wake_hook(std::function<void(WorldId)> hook) override { inner_->set_wake_hook(std::move(hook)); }
  void close() override { inner_->close(); }
  std::uint64_t messages_sent() const override { return inner_->messages_sent(); }
  std::uint64_t bytes_sent() const override { return inner_->bytes_sent(); }

 private:
  std::unique_ptr<Transport> inner_;
  FuzzRandom random_;
};

}  // namespace

void fuzz_pause(FuzzRandom& random) {
  const std::uint64_t r = random.next();
  if (r % 4 != 0) return;  // one call in four pauses
  const auto us = static_cast<int>((r >> 8) % 300);
  if (us < 20) {
    std::this_thread::yield();
  } else {
    std::this_thread::sleep_for(std::chrono::microseconds(us));
  }
}

std::unique_ptr<Transport> make_fuzzing_transport(std::unique_ptr<Transport> inner, std::uint64_t seed) {
  return std::make_unique<FuzzingTransport>(std::move(inner), seed);
}

}  // namespace soda
