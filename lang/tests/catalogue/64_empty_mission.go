// This mission compiles, with a warning: its entry point runs nothing.
package Empty

func INIT() {
}
