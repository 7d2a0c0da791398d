// A parameter type that is neither a drone type nor a number type.
package ParamType

var D1 Quadcopter

func INIT() {
	SEQ_Move(D1, 2)
}

func SEQ_Move(d Quadcopter, side flaot64) {
	d.FlyByX(side)
}
