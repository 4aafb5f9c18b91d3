#pragma once

// Defined when the tests are built with AddressSanitizer, which reserves terabytes of address
// space: `ulimit -v` stops such a process from starting.
#if defined(__SANITIZE_ADDRESS__)
#define TURBID_TEST_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define TURBID_TEST_ASAN 1
#endif
#endif
