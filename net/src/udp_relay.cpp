// UdpRelay: POSIX UDP sockets, one poll() loop, a due-time queue of datagrams.
#include "gauss/net/udp_relay.h"

#include <arpa/inet.h>
#include <netdb.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstring>
#include <map>
#include <mutex>
#include <queue>
#include <random>
#include <thread>
#include <vector>

namespace gauss::net {

using Clock = std::chrono::steady_clock;

namespace {

Expected<sockaddr_in> to_sockaddr(const Endpoint& e) {
  addrinfo hints{};
  hints.ai_family = AF_INET;
  hints.ai_socktype = SOCK_DGRAM;
  addrinfo* res = nullptr;
  if (getaddrinfo(e.host.c_str(), nullptr, &hints, &res) != 0 || res == nullptr)
    return Error{"relay: cannot resolve '" + e.host + "'"};
  sockaddr_in a{};
  std::memcpy(&a, res->ai_addr, sizeof(a));
  freeaddrinfo(res);
  a.sin_port = htons(e.port);
  return a;
}

Expected<int> bound_socket(const sockaddr_in& at) {
  const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
  if (fd < 0) return Error{std::string("relay: socket(): ") + std::strerror(errno)};
  if (::bind(fd, reinterpret_cast<const sockaddr*>(&at), sizeof(at)) != 0) {
    const std::string why = std::strerror(errno);
    ::close(fd);
    return Error{"relay: bind(): " + why};
  }
  return fd;
}

std::uint64_t key_of(const sockaddr_in& a) {
  return (std::uint64_t{ntohl(a.sin_addr.s_addr)} << 16) | ntohs(a.sin_port);
}

struct Datagram {
  Clock::time_point due;
  std::uint64_t seq{0};        // arrival order: ties keep it, reordering is counted against it
  int fd{-1};
  sockaddr_in to{};
  std::vector<std::uint8_t> bytes;
  bool operator>(const Datagram& o) const { return due != o.due ? due > o.due : seq > o.seq; }
};

Status check_policy(const RelayPolicy& p) {
  if (!(p.loss >= 0.0 && p.loss < 1.0)) return Error{"RelayPolicy: loss must be in [0, 1)"};
  if (!(p.duplicate >= 0.0 && p.duplicate <= 1.0)) return Error{"RelayPolicy: duplicate must be in [0, 1]"};
  if (p.delay.count() < 0 || p.jitter.count() < 0) return Error{"RelayPolicy: negative delay or jitter"};
  return Ok{};
}

}  // namespace

struct UdpRelay::Impl {
  int listen_fd{-1};
  sockaddr_in upstream{};
  std::uint16_t port{0};
  std::map<std::uint64_t, int> up_by_client;    // client address -> upstream socket
  std::map<int, sockaddr_in> client_by_up;      // upstream socket -> client address
  std::priority_queue<Datagram, std::vector<Datagram>, std::greater<>> queue;
  std::uint64_t next_seq{0};
  std::uint64_t last_delivered_seq{0};
  bool delivered_any{false};

  mutable std::mutex mu;  // policy, counters
  RelayPolicy policy;
  RelayCounters counters;
  std::mt19937_64 rng;
  std::thread thread;
  std::atomic<bool> stop{false};

  ~Impl() {
    if (thread.joinable()) {
      stop = true;
      thread.join();
    }
    for (auto& [fd, addr] : client_by_up) ::close(fd);
    if (listen_fd >= 0) ::close(listen_fd);
  }

  double uniform() { return std::uniform_real_distribution<double>(0.0, 1.0)(rng); }

  void schedule(int fd, const sockaddr_in& to, const std::uint8_t* data, std::size_t n, bool to_host) {
    std::lock_guard lock(mu);
    ++counters.received;
    const std::uint64_t seq = next_seq++;
    if (to_host && policy.drop_to_host && policy.drop_to_host(std::span<const std::uint8_t>(data, n))) {
      ++counters.filtered;
      return;
    }
    if (uniform() < policy.loss) {
      ++counters.dropped;
      return;
    }
    const int copies = uniform() < policy.duplicate ? 2 : 1;
    if (copies == 2) ++counters.duplicated;
    for (int c = 0; c < copies; ++c) {
      if (queue.size() >= policy.max_queued) {
        ++counters.overflow;
        return;
      }
      const auto jitter = policy.jitter.count() > 0
                              ? std::chrono::microseconds(static_cast<std::int64_t>(uniform() * double(policy.jitter.count())))
                              : std::chrono::microseconds(0);
      queue.push(Datagram{Clock::now() + policy.delay + jitter, seq, fd, to, std::vector<std::uint8_t>(data, data + n)});
    }
  }

  int upstream_for(const sockaddr_in& client) {
    const auto k = key_of(client);
    if (auto it = up_by_client.find(k); it != up_by_client.end()) return it->second;
    sockaddr_in any{};
    any.sin_family = AF_INET;
    any.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    auto fd = bound_socket(any);
    if (!fd) return -1;
    up_by_client[k] = fd.value();
    client_by_up[fd.value()] = client;
    std::lock_guard lock(mu);
    ++counters.sessions;
    return fd.value();
  }

  void deliver_due() {
    const auto now = Clock::now();
    while (!queue.empty() && queue.top().due <= now) {
      const Datagram& d = queue.top();
      ::sendto(d.fd, d.bytes.data(), d.bytes.size(), 0, reinterpret_cast<const sockaddr*>(&d.to), sizeof(d.to));
      {
        std::lock_guard lock(mu);
        ++counters.delivered;
        if (delivered_any && d.seq < last_delivered_seq) ++counters.reordered;
      }
      if (!delivered_any || d.seq > last_delivered_seq) last_delivered_seq = d.seq;
      delivered_any = true;
      queue.pop();
    }
  }

  void run() {
    std::vector<std::uint8_t> buf(65536);
    while (!stop.load()) {
      std::vector<pollfd> fds;
      fds.push_back({listen_fd, POLLIN, 0});
      for (auto& [fd, addr] : client_by_up) fds.push_back({fd, POLLIN, 0});
      int timeout_ms = 5;
      if (!queue.empty()) {
        const auto wait = std::chrono::duration_cast<std::chrono::milliseconds>(queue.top().due - Clock::now()).count();
        timeout_ms = static_cast<int>(std::clamp<std::int64_t>(wait, 0, 5));
      }
      if (::poll(fds.data(), fds.size(), timeout_ms) > 0) {
        for (const auto& p : fds) {
          if (!(p.revents & POLLIN)) continue;
          sockaddr_in from{};
          socklen_t len = sizeof(from);
          const ssize_t n = ::recvfrom(p.fd, buf.data(), buf.size(), 0, reinterpret_cast<sockaddr*>(&from), &len);
          if (n < 0) continue;
          if (p.fd == listen_fd) {
            const int up = upstream_for(from);
            if (up >= 0) schedule(up, upstream, buf.data(), static_cast<std::size_t>(n), true);
          } else {
            schedule(listen_fd, client_by_up[p.fd], buf.data(), static_cast<std::size_t>(n), false);
          }
        }
      }
      deliver_due();
    }
  }
};

UdpRelay::UdpRelay(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
UdpRelay::~UdpRelay() = default;

Expected<std::unique_ptr<UdpRelay>> UdpRelay::start(const Endpoint& listen, const Endpoint& upstream, RelayPolicy policy) {
  if (auto s = check_policy(policy); !s) return s.error();
  auto impl = std::make_unique<Impl>();
  auto up = to_sockaddr(upstream);
  if (!up) return up.error();
  impl->upstream = up.value();
  auto at = to_sockaddr(listen);
  if (!at) return at.error();
  auto fd = bound_socket(at.value());
  if (!fd) return Error{fd.message() + " (listen " + to_string(listen) + ")"};
  impl->listen_fd = fd.value();
  sockaddr_in bound{};
  socklen_t len = sizeof(bound);
  ::getsockname(impl->listen_fd, reinterpret_cast<sockaddr*>(&bound), &len);
  impl->port = ntohs(bound.sin_port);
  impl->policy = policy;
  impl->rng.seed(policy.seed);
  Impl* raw = impl.get();
  impl->thread = std::thread([raw] { raw->run(); });
  return std::unique_ptr<UdpRelay>(new UdpRelay(std::move(impl)));
}

std::uint16_t UdpRelay::port() const noexcept { return impl_->port; }

void UdpRelay::set_policy(const RelayPolicy& policy) {
  if (!check_policy(policy)) return;
  std::lock_guard lock(impl_->mu);
  impl_->policy = policy;
}

RelayCounters UdpRelay::counters() const {
  std::lock_guard lock(impl_->mu);
  return impl_->counters;
}

}  // namespace gauss::net
