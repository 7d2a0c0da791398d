// Strings only name events.
package StringCondition

var D1 Quadcopter

func INIT() {
	If("armed", SEQ_Go)
	Signal(armed)
	Await()
}

func SEQ_Go() {
	D1.Takeoff(1)
}
