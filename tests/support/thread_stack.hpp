// Runs f on a thread of its own with a stack of the given size (reserved, touched only as far as
// used). eom::Reference no longer needs a big one (its big AD numbers live on a heap stack,
// eom/reference/heap_stack.hpp); test_reference_stack uses this for a small one (1 MB). False when the
// thread could not be started. No test framework here: the report programs under bench/ use it
// too.
#pragma once

#include <cstddef>

#include <pthread.h>

template <class F> bool run_with_stack(std::size_t bytes, F f) {
  pthread_attr_t attr;
  pthread_attr_init(&attr);
  pthread_attr_setstacksize(&attr, bytes);
  pthread_t thread;
  auto body = [](void* arg) -> void* {
    (*static_cast<F*>(arg))();
    return nullptr;
  };
  const bool started = pthread_create(&thread, &attr, body, &f) == 0;
  if (started) pthread_join(thread, nullptr);
  pthread_attr_destroy(&attr);
  return started;
}
