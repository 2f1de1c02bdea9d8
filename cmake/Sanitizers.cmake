# GAUSS_SANITIZE=ON instruments everything built in this tree with ASan + UBSan.
# UBSan findings abort (no recovery) so a test fails instead of printing and passing.
if(GAUSS_SANITIZE)
  add_compile_options(-fsanitize=address,undefined -fno-sanitize-recover=all -fno-omit-frame-pointer)
  add_link_options(-fsanitize=address,undefined)
endif()
