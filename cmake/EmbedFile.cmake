# Files shipped inside the binary (the default scene, the `view` page): dofcache_embed_bytes(FILE
# VAR) sets VAR to FILE's bytes as C initialiser text ("0x..," with a line break after every 16
# bytes, to keep the generated source readable) and makes FILE a configure dependency, so editing
# it re-embeds it on the next build. The caller passes VAR to configure_file.
function(dofcache_embed_bytes file var)
  set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS ${file})
  file(READ ${file} hex HEX)
  string(REGEX REPLACE "([0-9a-f][0-9a-f])" "0x\\1," bytes "${hex}")
  string(REPEAT "0x[0-9a-f][0-9a-f]," 16 line)
  string(REGEX REPLACE "(${line})" "\\1\n" bytes "${bytes}")
  set(${var} "${bytes}" PARENT_SCOPE)
endfunction()
