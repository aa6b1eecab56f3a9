# examples/viewer.mk - picvr-viewer (examples/viewer.cpp), the interactive viewer: make rules
# included by the top Makefile at its end (they use its B, CC, CFLAGS, LDLIBS and LIB_SRC,
# and must not come before its first target, `all`).
#   make viewer        installs GLFW (tools/install-deps.sh viewer), builds build/picvr-viewer
#   make test-viewer   tools/check_viewer.sh: the viewer under Xvfb against picvr-render
# The viewer compiles the library itself (PICVR_IMPLEMENTATION in viewer.cpp, C++17); the
# example helpers it shares with picvr-render are C objects of their own.
.PHONY: viewer test-viewer deps-viewer

VIEWER_CXXFLAGS := -O2 -g -std=c++17 -Wall -Wextra -Wpedantic -Wshadow -I. -Icli
# Deferred (=): pkg-config runs only when the viewer is linked, after GLFW is installed.
VIEWER_LIBS = $(shell pkg-config --libs glfw3 2>/dev/null || echo -lglfw) -lstb -lz
VIEWER_C_OBJ := $(patsubst cli/%.c,$(B)/viewer/%.o,cli/cli.c cli/presets.c cli/env_io.c)

deps-viewer: $(B)/.deps-viewer
$(B)/.deps-viewer: tools/install-deps.sh | $(B)/.deps
	@sh tools/install-deps.sh viewer
	@touch $@

$(B)/viewer/%.o: cli/%.c cli/%.h picvr.h | $(B)/.deps
	@mkdir -p $(B)/viewer
	$(CC) $(CFLAGS) -c -o $@ $<

$(B)/picvr-viewer: examples/viewer.cpp $(VIEWER_C_OBJ) $(LIB_SRC) cli/cli.h cli/presets.h \
                   picvr_io.h cli/env_io.h $(B)/libpicvr_io.a | $(B)/.deps-viewer
	$(CXX) $(VIEWER_CXXFLAGS) -o $@ examples/viewer.cpp $(VIEWER_C_OBJ) $(B)/libpicvr_io.a $(LDLIBS) $(VIEWER_LIBS) $(IO_LIBS)

viewer: $(B)/picvr-viewer

test-viewer: $(B)/.deps-viewer $(B)/picvr-viewer $(B)/picvr-render
	DATA=$(DATA) sh tools/check_viewer.sh $(B)
