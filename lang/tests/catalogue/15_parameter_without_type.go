// The last parameter has no type, so neither has the one grouped with it.
package UntypedParam

var Drone1 Quadcopter

func INIT() {
	SEQ_Square(Drone1, 2)
}

func SEQ_Square(d, side) {
	d.FlyByX(side)
}
