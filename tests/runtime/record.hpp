// Records a measured figure in the test's XML output (ctest --output-junit, --gtest_output),
// in scientific notation: gtest's RecordProperty itself takes only strings and ints.
#pragma once

#include <gtest/gtest.h>

#include <cstdio>

inline void record_figure(const char* key, double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.3e", value);
  ::testing::Test::RecordProperty(key, text);
}
