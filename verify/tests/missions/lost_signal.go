// D2 waits for a signal that D1 only sends when its battery is above half.
package LostSignal

var D1 Quadcopter
var D2 Quadcopter

func PAR_Main() {
	SEQ_A()
	SEQ_B()
}

func SEQ_A() {
	If(D1.Battery() > 50, SEQ_Go)
	D1.Land()
}

func SEQ_Go() {
	Signal("go")
}

func SEQ_B() {
	Await("go")
	D2.Takeoff(1)
}
