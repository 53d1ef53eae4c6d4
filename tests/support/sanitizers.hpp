// Whether the test binary runs under AddressSanitizer (tools/sanitized_tests.sh): GCC defines
// __SANITIZE_ADDRESS__, clang answers __has_feature. Under ASan a child process that passes its
// memory limit does not throw std::bad_alloc: ASan's allocator prints its report and exits
// non-zero, so runContained says "ended without an answer" with ASan's last line. (A child that
// faults dies by the signal in every build: runContained restores the default action.)
#pragma once
#if defined(__SANITIZE_ADDRESS__)
#define PENUMBRA_TEST_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define PENUMBRA_TEST_ASAN 1
#endif
#endif
#ifndef PENUMBRA_TEST_ASAN
#define PENUMBRA_TEST_ASAN 0
#endif
