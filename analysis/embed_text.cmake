# Writes a C++ source defining `const char* const NAME` as the text of INPUT (a raw string
# literal), so a page template ships inside the executable. Run at build time:
#   cmake -DINPUT=file -DOUTPUT=file.cpp -DNAME=kName -P embed_text.cmake
file(READ ${INPUT} text)
string(FIND "${text}" ")VEILTEXT\"" clash)
if(NOT clash EQUAL -1)
  message(FATAL_ERROR "${INPUT} contains the raw string delimiter )VEILTEXT\"")
endif()
file(WRITE ${OUTPUT}.tmp "// Generated from ${INPUT} by analysis/embed_text.cmake: do not edit.\nnamespace veil {\nextern const char* const ${NAME};\nconst char* const ${NAME} = R\"VEILTEXT(${text})VEILTEXT\";\n}  // namespace veil\n")
file(RENAME ${OUTPUT}.tmp ${OUTPUT})
