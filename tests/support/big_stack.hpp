// eom::Reference keeps its AD numbers on the stack: for the derivatives of a 10-link body-form
// chain (or AD over 26 parameters) each scalar carries thousands of doubles, several MB in all,
// beyond the main thread's 8 MB. Such checks run f on a thread with a 256 MB stack.
#pragma once

#include <cstddef>

#include <gtest/gtest.h>
#include <pthread.h>

template <class F> void on_big_stack(F f) {
  pthread_attr_t attr;
  pthread_attr_init(&attr);
  pthread_attr_setstacksize(&attr, std::size_t{256} << 20);
  pthread_t thread;
  auto body = [](void* arg) -> void* {
    (*static_cast<F*>(arg))();
    return nullptr;
  };
  ASSERT_EQ(pthread_create(&thread, &attr, body, &f), 0);
  pthread_join(thread, nullptr);
  pthread_attr_destroy(&attr);
}
