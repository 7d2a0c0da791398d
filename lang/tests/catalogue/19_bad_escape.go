// An unknown escape sequence in an event name.
package Escape

var D1 Quadcopter

func INIT() {
	D1.Arm()
	Signal("a\qb")
	Await("a\qb")
}
