# SPDX-License-Identifier: Apache-2.0
# Warnings for the project's own code: every target we write calls rtm_warnings(target).
# Generated IDL stubs and third-party headers are not ours and are kept out of -Werror
# (their include directories are marked SYSTEM).
function(rtm_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Werror)
endfunction()
