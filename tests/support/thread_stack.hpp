// Runs f on a thread of its own with a large stack (reserved, touched only as far as used):
// eom::Reference keeps its AD numbers on the stack, and for big models (derivatives of a 10-link
// body-form chain, AD over 26 parameters, a 100-link chain in long double) they need far more
// than the main thread's 8 MB. False when the thread could not be started. No test framework
// here: the report programs under bench/ use it too (tests use big_stack.hpp's on_big_stack).
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
