// Empty on purpose: gives a precompiled-header kind (cmake/Pch.cmake) a target to be built in.
