# FSP_FUZZ=ON: the fuzz build (fuzz/README.md, scripts/fuzz.sh). libFuzzer comes with clang, so
# the compiler must be clang; every library is compiled with libFuzzer's coverage instrumentation
# and the sanitizers of FSP_FUZZ_SANITIZERS, which stop at their first report (a finding).
if(NOT CMAKE_CXX_COMPILER_ID MATCHES "Clang")
  message(FATAL_ERROR
    "FSP_FUZZ=ON needs clang (libFuzzer is part of clang), but the C++ compiler is "
    "${CMAKE_CXX_COMPILER_ID} (${CMAKE_CXX_COMPILER}). Configure a separate build directory with "
    "-DCMAKE_CXX_COMPILER=clang++ (Debian: apt-get install clang libclang-rt-14-dev), or run "
    "scripts/fuzz.sh, which does.")
endif()
# As the asan preset: Debian's libceres allocates with plain malloc (README, "Set-up").
add_compile_options(-fsanitize=fuzzer-no-link,${FSP_FUZZ_SANITIZERS} -fno-sanitize-recover=all
                    -fno-omit-frame-pointer -DEIGEN_MALLOC_ALREADY_ALIGNED=1)
add_link_options(-fsanitize=${FSP_FUZZ_SANITIZERS})
