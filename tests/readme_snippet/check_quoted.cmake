# README.md must quote SNIPPET verbatim, as a ```cpp block (tests/readme_snippet/tests.cmake).
file(READ "${README}" readme)
file(READ "${SNIPPET}" snippet)
string(FIND "${readme}" "```cpp\n${snippet}```" at)
if(at EQUAL -1)
  message(FATAL_ERROR "${README} does not quote ${SNIPPET} verbatim: copy the file's text into the "
                      "README's ```cpp block (the snippet is compiled by readme_snippet.tree and .loops)")
endif()
message(STATUS "README.md quotes ${SNIPPET} verbatim")
