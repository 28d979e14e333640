// SPDX-License-Identifier: Apache-2.0
// rtm-container: several components in one process (host/module.h, docs/system-files.md).
#include "host/module.h"

int main(int argc, char** argv) { return rtm::run_container(argc, argv); }
