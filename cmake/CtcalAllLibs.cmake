# The list of every ctcal library that exists at this point of the build, for apps, tests and
# benchmarks that wire several together.
set(CTCAL_ALL_LIBS "")
foreach(lib spline sensors targets sim report calibrator)
  if(TARGET ctcal_${lib})
    list(APPEND CTCAL_ALL_LIBS ctcal::${lib})
  endif()
endforeach()
