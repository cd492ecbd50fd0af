// on_big_stack(f): f on a thread with a 256 MB stack, failing the test when the thread cannot be
// started (see thread_stack.hpp for why).
#pragma once

#include <cstddef>

#include <gtest/gtest.h>

#include "thread_stack.hpp"

template <class F> void on_big_stack(F f) { ASSERT_TRUE(run_with_stack(std::size_t{256} << 20, f)); }
