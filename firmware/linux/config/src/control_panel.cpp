#include "fw_linux/control_panel.hpp"

namespace fw_linux {

void ControlPanel::publish(const PanelStatus& status) {
  std::unique_lock lock(mutex_, std::try_to_lock);
  if (lock.owns_lock()) status_ = status;
}

PanelStatus ControlPanel::status() const {
  std::lock_guard lock(mutex_);
  return status_;
}

std::optional<CommandVerdict> ControlPanel::submit(PanelCommand command,
                                                   std::chrono::milliseconds timeout) {
  std::unique_lock lock(mutex_);
  if (pending_) return std::nullopt;
  const std::uint64_t ticket = ++next_ticket_;
  pending_ = std::move(command);
  pending_ticket_ = ticket;
  if (!answered_.wait_for(lock, timeout, [&] { return verdict_ticket_ == ticket; })) {
    if (pending_ && pending_ticket_ == ticket) pending_.reset();  // withdrawn, never taken
    if (verdict_ticket_ != ticket) return std::nullopt;
  }
  return verdict_;
}

}  // namespace fw_linux
