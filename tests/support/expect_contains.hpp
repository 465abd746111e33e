// EXPECT_CONTAINS(text, part): the text (a message, a program's output) contains part; on failure
// the whole text is printed.
#pragma once

#include <string>

#include <gtest/gtest.h>

#define EXPECT_CONTAINS(text, part) \
  EXPECT_NE(std::string(text).find(part), std::string::npos) << "text lacks '" << (part) << "':\n" << (text)
