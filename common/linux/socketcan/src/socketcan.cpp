#include "delta/can/socketcan.hpp"

#include <errno.h>
#include <fcntl.h>
#include <linux/can.h>
#include <linux/can/error.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <sys/uio.h>
#include <unistd.h>

#include <cstdio>
#include <cstring>
#include <utility>

namespace delta::can {

namespace {

std::string errno_text(int e) {
  return std::strerror(e);
}

// A raw CAN socket, non-blocking; a kernel without CAN is told how to get it.
int open_raw_socket() {
  const int fd = ::socket(PF_CAN, SOCK_RAW | SOCK_NONBLOCK | SOCK_CLOEXEC, CAN_RAW);
  if (fd < 0) {
    const int e = errno;
    if (e == EAFNOSUPPORT || e == EPROTONOSUPPORT) {
      throw CanError("this kernel has no CAN support (socket(AF_CAN) failed: " + errno_text(e) +
                     "); load the can and can-raw modules, or run under hil/vcan-run");
    }
    throw CanError("cannot open a CAN socket: " + errno_text(e));
  }
  return fd;
}

int interface_index(int fd, const std::string& iface) {
  ifreq ifr{};
  std::memcpy(ifr.ifr_name, iface.c_str(), iface.size() + 1);
  if (::ioctl(fd, SIOCGIFINDEX, &ifr) < 0) {
    const int e = errno;
    throw CanError(e == ENODEV
                       ? "CAN interface '" + iface + "' does not exist (ip link show " + iface + ")"
                       : "CAN interface '" + iface + "': " + errno_text(e));
  }
  return ifr.ifr_ifindex;
}

// The frames to receive: every error frame, and those the filters pass
// (all where there are none).
void set_filters(int fd, const std::string& iface, const std::vector<Filter>& filters) {
  // Error frames: all classes.
  const can_err_mask_t err_mask = CAN_ERR_MASK;
  ::setsockopt(fd, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &err_mask, sizeof err_mask);
  if (filters.empty()) return;
  std::vector<can_filter> kf;
  for (const Filter& f : filters) {
    can_filter k{};
    k.can_id = f.extended ? (f.id | CAN_EFF_FLAG) : f.id;
    k.can_mask = f.mask | CAN_EFF_FLAG | CAN_RTR_FLAG;
    if (f.extended) k.can_mask = (f.mask & CAN_EFF_MASK) | CAN_EFF_FLAG;
    kf.push_back(k);
  }
  if (::setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FILTER, kf.data(),
                   static_cast<socklen_t>(kf.size() * sizeof(can_filter))) < 0) {
    throw CanError("CAN interface '" + iface + "': cannot set filters: " + errno_text(errno));
  }
}

// Kernel timestamps, the receive buffer's size where given, and the
// kernel's drop counter.
void set_receive_options(int fd, const std::string& iface, int receive_buffer_bytes) {
  const int on = 1;
  if (::setsockopt(fd, SOL_SOCKET, SO_TIMESTAMPNS, &on, sizeof on) < 0) {
    throw CanError("CAN interface '" + iface + "': no kernel timestamps: " + errno_text(errno));
  }
  if (receive_buffer_bytes > 0 &&
      ::setsockopt(fd, SOL_SOCKET, SO_RCVBUFFORCE, &receive_buffer_bytes,
                   sizeof receive_buffer_bytes) < 0) {
    ::setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &receive_buffer_bytes, sizeof receive_buffer_bytes);
  }
  if (::setsockopt(fd, SOL_SOCKET, SO_RXQ_OVFL, &on, sizeof on) < 0) {
    throw CanError("CAN interface '" + iface + "': no drop counter: " + errno_text(errno));
  }
}

}  // namespace

Socket Socket::open(const std::string& iface, const std::vector<Filter>& filters,
                    int receive_buffer_bytes) {
  if (iface.empty() || iface.size() >= IFNAMSIZ) {
    throw CanError("CAN interface name '" + iface + "' is empty or longer than " +
                   std::to_string(IFNAMSIZ - 1) + " characters");
  }
  const int fd = open_raw_socket();
  Socket s(fd, iface);  // closes the socket if what follows throws
  const int index = interface_index(fd, iface);
  set_filters(fd, iface, filters);
  set_receive_options(fd, iface, receive_buffer_bytes);
  sockaddr_can addr{};
  addr.can_family = AF_CAN;
  addr.can_ifindex = index;
  if (::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) < 0) {
    throw CanError("CAN interface '" + iface + "': bind failed: " + errno_text(errno));
  }
  return s;
}

Socket::Socket(Socket&& other) noexcept
    : fd_(std::exchange(other.fd_, -1)), iface_(std::move(other.iface_)) {}

Socket& Socket::operator=(Socket&& other) noexcept {
  if (this != &other) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = std::exchange(other.fd_, -1);
    iface_ = std::move(other.iface_);
  }
  return *this;
}

Socket::~Socket() {
  if (fd_ >= 0) ::close(fd_);
}

void Socket::set_receive_own(bool on) {
  const int v = on ? 1 : 0;
  ::setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_RECV_OWN_MSGS, &v, sizeof v);
}

SendResult Socket::send(const Frame& f) {
  can_frame k{};
  k.can_id = f.extended ? ((f.id & CAN_EFF_MASK) | CAN_EFF_FLAG) : (f.id & CAN_SFF_MASK);
  if (f.remote) k.can_id |= CAN_RTR_FLAG;
  if (f.error_frame) k.can_id = CAN_ERR_FLAG | (f.id & CAN_ERR_MASK);
  k.can_dlc = f.dlc > 8 ? 8 : f.dlc;
  std::memcpy(k.data, f.data.data(), 8);
  const ssize_t n = ::write(fd_, &k, sizeof k);
  if (n == static_cast<ssize_t>(sizeof k)) return SendResult::kOk;
  if (n < 0 && (errno == EAGAIN || errno == ENOBUFS)) return SendResult::kWouldBlock;
  if (n < 0 && (errno == ENETDOWN || errno == ENXIO)) return SendResult::kNetworkDown;
  return SendResult::kError;
}

std::optional<Received> Socket::receive() {
  can_frame k{};
  iovec iov{&k, sizeof k};
  alignas(cmsghdr) char control[CMSG_SPACE(sizeof(timespec)) + CMSG_SPACE(sizeof(std::uint32_t))];
  msghdr msg{};
  msg.msg_iov = &iov;
  msg.msg_iovlen = 1;
  msg.msg_control = control;
  msg.msg_controllen = sizeof control;
  const ssize_t n = ::recvmsg(fd_, &msg, MSG_DONTWAIT);
  if (n != static_cast<ssize_t>(sizeof k)) return std::nullopt;
  Received r;
  r.frame.extended = (k.can_id & CAN_EFF_FLAG) != 0;
  r.frame.remote = (k.can_id & CAN_RTR_FLAG) != 0;
  r.frame.id = r.frame.extended ? (k.can_id & CAN_EFF_MASK) : (k.can_id & CAN_SFF_MASK);
  r.frame.dlc = k.can_dlc > 8 ? 8 : k.can_dlc;
  std::memcpy(r.frame.data.data(), k.data, 8);
  for (cmsghdr* c = CMSG_FIRSTHDR(&msg); c != nullptr; c = CMSG_NXTHDR(&msg, c)) {
    if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SO_TIMESTAMPNS) {
      timespec ts{};
      std::memcpy(&ts, CMSG_DATA(c), sizeof ts);
      r.kernel_time = std::chrono::seconds(ts.tv_sec) + std::chrono::nanoseconds(ts.tv_nsec);
    } else if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SO_RXQ_OVFL) {
      std::memcpy(&r.socket_drops, CMSG_DATA(c), sizeof r.socket_drops);
    }
  }
  if (k.can_id & CAN_ERR_FLAG) {
    r.frame.error_frame = true;
    r.frame.id = k.can_id & CAN_ERR_MASK;
    r.error = decode_error_frame(k.can_id & CAN_ERR_MASK, r.frame.data);
  }
  return r;
}

bool Socket::wait_readable(std::chrono::milliseconds timeout) {
  pollfd p{fd_, POLLIN, 0};
  for (;;) {
    const int n = ::poll(&p, 1, static_cast<int>(timeout.count()));
    if (n < 0 && errno == EINTR) continue;
    return n > 0 && (p.revents & POLLIN) != 0;
  }
}

BusError decode_error_frame(std::uint32_t can_id, const std::array<std::uint8_t, 8>& data) {
  BusError e;
  e.raw_class = can_id & CAN_ERR_MASK;
  e.bus_off = (can_id & CAN_ERR_BUSOFF) != 0;
  e.lost_arbitration = (can_id & CAN_ERR_LOSTARB) != 0;
  e.protocol_violation = (can_id & CAN_ERR_PROT) != 0;
  e.no_ack = (can_id & CAN_ERR_ACK) != 0;
  e.restarted = (can_id & CAN_ERR_RESTARTED) != 0;
  if (can_id & CAN_ERR_CRTL) {
    const std::uint8_t c = data[1];
    e.error_passive = (c & (CAN_ERR_CRTL_RX_PASSIVE | CAN_ERR_CRTL_TX_PASSIVE)) != 0;
    e.warning = (c & (CAN_ERR_CRTL_RX_WARNING | CAN_ERR_CRTL_TX_WARNING)) != 0;
  }
  return e;
}

std::string describe(const Frame& f) {
  char buf[64];
  int n = std::snprintf(buf, sizeof buf, f.extended ? "0x%08X [%u]" : "0x%03X [%u]", f.id,
                        static_cast<unsigned>(f.dlc));
  for (unsigned i = 0; i < f.dlc && n > 0 && static_cast<std::size_t>(n) + 4 < sizeof buf; ++i) {
    n += std::snprintf(buf + n, sizeof buf - static_cast<std::size_t>(n), " %02X", f.data[i]);
  }
  return buf;
}

}  // namespace delta::can
