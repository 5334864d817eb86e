# SPDX-License-Identifier: Apache-2.0
# Fails unless README.md contains, verbatim, the lines of quickstart.c between "/* README-BEGIN */" and
# "/* README-END */" (the README shows them in a ```c block).
file(READ "${SRC}" src)
file(READ "${README}" readme)
string(FIND "${src}" "/* README-BEGIN */\n" b)
string(FIND "${src}" "/* README-END */" e)
if(b LESS 0 OR e LESS 0)
  message(FATAL_ERROR "quickstart.c: README markers not found")
endif()
string(LENGTH "/* README-BEGIN */\n" blen)
math(EXPR start "${b} + ${blen}")
math(EXPR len "${e} - ${start}")
string(SUBSTRING "${src}" ${start} ${len} snippet)
string(FIND "${readme}" "```c\n${snippet}```" found)
if(found LESS 0)
  message(FATAL_ERROR "README.md does not show the quickstart of examples/quickstart/quickstart.c verbatim: "
                      "copy the lines between its README markers into the README's ```c block")
endif()
message(STATUS "README quickstart matches examples/quickstart/quickstart.c")
