// cli.hpp - one CLI11 set-up and parse for every tool: `--version`, `--help`, and usage errors
// as one line `tool: message (see tool --help)` with exit status 2.
#pragma once

#include <CLI/CLI.hpp>
#include <cstdio>

#include "omni4/version.h"

// Adds --version (the project version and the git description of the tree it was built from).
inline void omni4_cli_setup(CLI::App &app)
{
	app.set_version_flag("--version", std::string(app.get_name()) + " " + OMNI4_VERSION);
}

// Use in main(): parses, prints --help / --version (status 0) or the usage error (status 2,
// one line) and returns.
#define OMNI4_CLI_PARSE(app, argc, argv)                                                           \
	do {                                                                                       \
		try {                                                                              \
			(app).parse((argc), (argv));                                               \
		} catch (const CLI::CallForHelp &e_) {                                             \
			return (app).exit(e_);                                                     \
		} catch (const CLI::CallForAllHelp &e_) {                                          \
			return (app).exit(e_);                                                     \
		} catch (const CLI::CallForVersion &e_) {                                          \
			return (app).exit(e_);                                                     \
		} catch (const CLI::ParseError &e_) {                                              \
			std::fprintf(stderr, "%s: %s (see %s --help)\n", (app).get_name().c_str(), \
			             e_.what(), (app).get_name().c_str());                         \
			return 2;                                                                  \
		}                                                                                  \
	} while (0)
