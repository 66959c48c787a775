// The bounded queue in front of every stage, with its overflow policy stated at construction:
//   Block       push() waits for room: the stage sees every item; the producer (a pipeline thread,
//               never the session server's) is held back instead.
//   DropOldest  push() evicts the oldest waiting item (counted) and never waits: a live consumer
//               always works on the newest frames.
//   DropNewest  push() refuses the new item (counted) and never waits: the session thread's hand-off
//               to the assembly stage, which must not block.
// close() ends it: pushes fail from then on (waiting producers wake and fail), pops drain what is
// left and then return nothing. Thread-safe; any number of producers and consumers.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <utility>

namespace vc::pipeline {

enum class Overflow { Block, DropOldest, DropNewest };

const char* overflow_name(Overflow o);

struct QueueCounters {
  uint64_t pushed = 0;          // items accepted
  uint64_t dropped = 0;         // DropOldest: evicted; DropNewest: refused
  uint64_t refused_closed = 0;  // pushes after close()
  uint64_t blocked = 0;         // Block: pushes that had to wait for room
  size_t depth = 0, max_depth = 0, capacity = 0;
};

template <class T>
class BoundedQueue {
 public:
  BoundedQueue(size_t capacity, Overflow overflow) : cap_(capacity), overflow_(overflow) {
    if (capacity == 0) throw std::invalid_argument("queue capacity must be > 0");
  }

  // By the policy. True when the item was queued (DropOldest: always, unless closed).
  bool push(T item) {
    std::unique_lock<std::mutex> l(mu_);
    if (closed_) return refuse_closed();
    if (q_.size() >= cap_) {
      switch (overflow_) {
        case Overflow::Block:
          c_.blocked++;
          not_full_.wait(l, [&] { return closed_ || q_.size() < cap_; });
          if (closed_) return refuse_closed();
          break;
        case Overflow::DropOldest:
          q_.pop_front();
          c_.dropped++;
          break;
        case Overflow::DropNewest:
          c_.dropped++;
          return false;
      }
    }
    q_.push_back(std::move(item));
    c_.pushed++;
    if (q_.size() > c_.max_depth) c_.max_depth = q_.size();
    l.unlock();
    not_empty_.notify_one();
    return true;
  }

  // Queues the item even when the queue is full, by any policy: never waits, never drops. For rare
  // control items that must keep their order with the data (a node starting or stopping); they are
  // not counted against the capacity's purpose, so keep them rare. False only when closed.
  bool push_always(T item) {
    std::unique_lock<std::mutex> l(mu_);
    if (closed_) return refuse_closed();
    q_.push_back(std::move(item));
    c_.pushed++;
    if (q_.size() > c_.max_depth) c_.max_depth = q_.size();
    l.unlock();
    not_empty_.notify_one();
    return true;
  }

  // Waits up to `timeout` for an item; nothing when it timed out, or when closed and empty.
  std::optional<T> pop_for(std::chrono::nanoseconds timeout) {
    std::unique_lock<std::mutex> l(mu_);
    if (!not_empty_.wait_for(l, timeout, [&] { return closed_ || !q_.empty(); })) return std::nullopt;
    return take(l);
  }
  // Waits for an item; nothing once closed and drained.
  std::optional<T> pop() {
    std::unique_lock<std::mutex> l(mu_);
    not_empty_.wait(l, [&] { return closed_ || !q_.empty(); });
    return take(l);
  }

  void close() {
    {
      std::lock_guard<std::mutex> g(mu_);
      closed_ = true;
    }
    not_empty_.notify_all();
    not_full_.notify_all();
  }
  bool closed_and_empty() const {
    std::lock_guard<std::mutex> g(mu_);
    return closed_ && q_.empty();
  }
  QueueCounters counters() const {
    std::lock_guard<std::mutex> g(mu_);
    QueueCounters c = c_;
    c.depth = q_.size();
    c.capacity = cap_;
    return c;
  }
  Overflow overflow() const { return overflow_; }

 private:
  bool refuse_closed() {
    c_.refused_closed++;
    return false;
  }
  std::optional<T> take(std::unique_lock<std::mutex>& l) {
    if (q_.empty()) return std::nullopt;
    std::optional<T> v(std::move(q_.front()));
    q_.pop_front();
    l.unlock();
    not_full_.notify_one();
    return v;
  }

  const size_t cap_;
  const Overflow overflow_;
  mutable std::mutex mu_;
  std::condition_variable not_empty_, not_full_;
  std::deque<T> q_;
  bool closed_ = false;
  QueueCounters c_;
};

}  // namespace vc::pipeline
