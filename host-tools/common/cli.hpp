// cli.hpp - one CLI11 parse for every tool: usage errors exit with status 2 and one line.
#pragma once

#include <CLI/CLI.hpp>

// Use in main(): parses, prints --help (status 0) or the usage error (status 2) and returns.
#define OMNI4_CLI_PARSE(app, argc, argv)                 \
  do {                                                   \
    try {                                                \
      (app).parse((argc), (argv));                       \
    } catch (const CLI::ParseError &e_) {                \
      return (app).exit(e_) == 0 ? 0 : 2;                \
    }                                                    \
  } while (0)
