// eom::detail::on_heap_stack(f): runs f() on a stack that the calling thread owns on the heap,
// not on the thread's own stack.
//
// eom::Reference evaluates the model on AD numbers that hold a gradient and a Hessian inline, and
// the model's code keeps arrays of them in its frames (a tree's links, its bodies), so its stack
// use grows with the square of the coordinates times the links: about 30 MB for a 50-link chain,
// far more for the derivatives of a humanoid, where a thread has 8 MB (the main thread's default)
// or less. The Reference therefore runs each kernel on this stack: one region per thread, reserved
// once (the first call on that thread) as address space only (MAP_NORESERVE), so that memory is
// committed only as deep as a call actually reaches, and kept until the thread exits. Switching
// costs two swapcontext calls per kernel (about a microsecond; the Reference is the oracle, not
// the fast path). A call made while already on it (a kernel inside a kernel) runs directly.
//
// The reservation is heap_stack_bytes (4 GiB; smaller halves down to 64 MiB when the address space
// is short); a call deeper than that still overflows, into a guard page. Where this is not a
// glibc/Linux (POSIX ucontext) build, or no region can be mapped, f runs on the caller's stack as
// before.
#pragma once

#include <cstddef>
#include <type_traits>

#if defined(__linux__) && defined(__GLIBC__)
#define EOM_HEAP_STACK 1
#include <sys/mman.h>
#include <ucontext.h>
#include <unistd.h>
#endif

#if defined(__SANITIZE_ADDRESS__)
#define EOM_HEAP_STACK_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define EOM_HEAP_STACK_ASAN 1
#endif
#endif
#ifdef EOM_HEAP_STACK_ASAN
#include <sanitizer/common_interface_defs.h>
#endif

namespace eom::detail {

inline constexpr std::size_t heap_stack_bytes = std::size_t{4} << 30;

#ifdef EOM_HEAP_STACK
class HeapStack {
 public:
  HeapStack() = default;
  HeapStack(const HeapStack&) = delete;
  HeapStack& operator=(const HeapStack&) = delete;
  ~HeapStack() {
    if (base_) munmap(base_, size_);
  }

  // Runs call(arg) on this stack (or directly when nested or when no stack could be mapped).
  void run(void (*call)(void*), void* arg) noexcept {
    if (active_ || !reserve()) {
      call(arg);
      return;
    }
    call_ = call;
    arg_ = arg;
    getcontext(&callee_);
    callee_.uc_stack.ss_sp = base_;
    callee_.uc_stack.ss_size = size_;
    callee_.uc_link = &caller_;
    makecontext(&callee_, &HeapStack::trampoline, 0);
    active_ = true;
#ifdef EOM_HEAP_STACK_ASAN
    void* fake = nullptr;
    __sanitizer_start_switch_fiber(&fake, base_, size_);
#endif
    swapcontext(&caller_, &callee_);
#ifdef EOM_HEAP_STACK_ASAN
    __sanitizer_finish_switch_fiber(fake, nullptr, nullptr);
#endif
    active_ = false;
  }

  static HeapStack& of_this_thread() noexcept {
    static thread_local HeapStack stack;
    return stack;
  }

  std::size_t reserved_bytes() const noexcept { return size_; }

 private:
  bool reserve() noexcept {
    if (base_) return true;
    if (failed_) return false;
    for (std::size_t bytes = heap_stack_bytes; bytes >= (std::size_t{64} << 20); bytes /= 2) {
      void* p = mmap(nullptr, bytes, PROT_READ | PROT_WRITE,
                     MAP_PRIVATE | MAP_ANONYMOUS | MAP_NORESERVE | MAP_STACK, -1, 0);
      if (p == MAP_FAILED) continue;
      // The lowest page is the guard: an overflow faults there instead of writing past the region.
      mprotect(p, static_cast<std::size_t>(sysconf(_SC_PAGESIZE)), PROT_NONE);
      base_ = p;
      size_ = bytes;
      return true;
    }
    failed_ = true;
    return false;
  }

  static void trampoline() noexcept {
    HeapStack& s = of_this_thread();
#ifdef EOM_HEAP_STACK_ASAN
    __sanitizer_finish_switch_fiber(nullptr, &s.caller_bottom_, &s.caller_size_);
#endif
    s.call_(s.arg_);
#ifdef EOM_HEAP_STACK_ASAN
    // This fiber ends (its fake frames go with it): back to the caller's stack.
    __sanitizer_start_switch_fiber(nullptr, s.caller_bottom_, s.caller_size_);
#endif
  }

  void* base_ = nullptr;
  std::size_t size_ = 0;
  bool failed_ = false, active_ = false;
  void (*call_)(void*) = nullptr;
  void* arg_ = nullptr;
  ucontext_t caller_{}, callee_{};
#ifdef EOM_HEAP_STACK_ASAN
  const void* caller_bottom_ = nullptr;
  std::size_t caller_size_ = 0;
#endif
};
#endif

// f() on the calling thread's heap stack; f must not throw (an exception cannot leave it).
template <class F> void on_heap_stack(F&& f) noexcept {
#ifdef EOM_HEAP_STACK
  using G = std::remove_reference_t<F>;
  HeapStack::of_this_thread().run([](void* arg) { (*static_cast<G*>(arg))(); },
                                  const_cast<void*>(static_cast<const void*>(&f)));
#else
  f();
#endif
}

}  // namespace eom::detail
