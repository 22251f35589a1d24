// Vector table, reset handler and semihosting for the Cortex-M test image.
// No libc start-up files: .data is copied, .bss zeroed, constructors run,
// then firmware_main(); its return code leaves qemu through semihosting.
#include <cstdint>

#include "semihosting.hpp"

extern "C" {
extern std::uint32_t _sidata, _sdata, _edata, _sbss, _ebss, _estack;
extern void (*__init_array_start[])();
extern void (*__init_array_end[])();
int firmware_main();  // the image's entry, called by Reset_Handler
[[noreturn]] void Reset_Handler();
[[noreturn]] void Fault_Handler();
}

namespace semihosting {

namespace {
std::uint32_t call(std::uint32_t op, const void* arg) {
  register std::uint32_t r0 asm("r0") = op;
  register const void* r1 asm("r1") = arg;
  asm volatile("bkpt 0xAB" : "+r"(r0) : "r"(r1) : "memory");
  return r0;
}
}  // namespace

void write(const char* text) {
  call(0x04, text);
}  // SYS_WRITE0

[[noreturn]] void exit(int code) {
  // SYS_EXIT_EXTENDED: {ADP_Stopped_ApplicationExit, exit code}.
  const std::uint32_t block[2] = {0x20026u, static_cast<std::uint32_t>(code)};
  call(0x20, block);
  for (;;) {
  }
}

}  // namespace semihosting

extern "C" [[noreturn]] void Reset_Handler() {
  // Full access to the FPU (CPACR CP10/CP11), in case any library code uses it.
  *reinterpret_cast<volatile std::uint32_t*>(0xE000ED88u) |= (0xFu << 20);
  for (std::uint32_t *src = &_sidata, *dst = &_sdata; dst < &_edata;) *dst++ = *src++;
  for (std::uint32_t* dst = &_sbss; dst < &_ebss;) *dst++ = 0;
  for (auto f = __init_array_start; f < __init_array_end; ++f) (*f)();
  semihosting::exit(firmware_main());
}

extern "C" [[noreturn]] void Fault_Handler() {
  semihosting::write("fault: the image took an exception\n");
  semihosting::exit(99);
}

namespace {
struct VectorTable {
  std::uint32_t* initial_stack;
  void (*handlers[15])();
};
}  // namespace

__attribute__((section(".isr_vector"), used)) const VectorTable kVectors = {
    &_estack,
    {Reset_Handler, Fault_Handler, Fault_Handler, Fault_Handler, Fault_Handler, Fault_Handler,
     nullptr, nullptr, nullptr, nullptr, Fault_Handler, Fault_Handler, nullptr, Fault_Handler,
     Fault_Handler}};
