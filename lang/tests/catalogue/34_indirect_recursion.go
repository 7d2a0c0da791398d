// A cycle of three blocks, one link through a block argument; no function
// is left to start from.
package Cycle

var D1 Quadcopter

func SEQ_A() {
	SEQ_B()
}

func SEQ_B() {
	If(D1.Z() > 1, SEQ_C)
}

func SEQ_C() {
	D1.Land()
	SEQ_A()
}
