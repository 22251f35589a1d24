# With DELTA_SANITIZE=ON every target is built with AddressSanitizer and
# UndefinedBehaviorSanitizer; any report aborts the program, so a test that
# triggers one fails.
if(DELTA_SANITIZE)
  add_compile_options(-fsanitize=address,undefined -fno-sanitize-recover=all
                      -fno-omit-frame-pointer)
  add_link_options(-fsanitize=address,undefined)
endif()
